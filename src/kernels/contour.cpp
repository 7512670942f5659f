// Exact unobstructed form factors: Lambert's formula (point → polygon) and the double contour
// integral of Stokes' theorem (polygon → polygon). See docs/analytic.md.

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/fast_atan.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"

namespace formfactor {

namespace {

constexpr double kTwoPi = 2.0 * kPi;

// A length scale for relative tolerances: diameters plus the distance between the polygons.
double pair_scale(const Polygon& a, const Polygon& b) {
    Bounds3 box;
    for (const Vec3& v : a.vertices) box.extend(v);
    for (const Vec3& v : b.vertices) box.extend(v);
    return box.diagonal().norm();
}

// True when no vertex of p is strictly in front of the plane (beyond eps).
bool nothing_in_front(const Polygon& p, const Plane& plane, double eps) {
    for (const Vec3& v : p.vertices)
        if (plane.signed_distance(v) > eps) return false;
    return true;
}

// True when every vertex of each polygon is in front of (or on) the other's plane.
bool far_field_ok(const Polygon& a, const Plane& pa, const Polygon& b, const Plane& pb,
                  double eps) {
    for (const Vec3& v : b.vertices)
        if (pa.signed_distance(v) < -eps) return false;
    for (const Vec3& v : a.vertices)
        if (pb.signed_distance(v) < -eps) return false;
    return true;
}

// F_ab by Gauss rules with an error bound ≤ 1e-15 when the pair is well separated
// ((R_a + R_b)/d ≤ 1/4), else −1.
double far_field_exact(const Polygon& a, const Polygon& b, double area_a) {
    const Vec3 ca = centroid(a), cb = centroid(b);
    FarFieldPair pr;
    for (const Vec3& v : a.vertices) pr.radius_a = std::max(pr.radius_a, (v - ca).norm());
    for (const Vec3& v : b.vertices) pr.radius_b = std::max(pr.radius_b, (v - cb).norm());
    pr.area_a = area_a;
    pr.area_b = area(b);
    pr.distance = (cb - ca).norm();
    if (!(pr.radius_a + pr.radius_b <= 0.25 * pr.distance)) return -1.0;
    const double target = 5e-16;
    int oa = 0, ob = 0;
    for (int n = 1; n <= detail::kMaxGaussOrder && oa == 0; ++n)
        if (far_field_error_bound(pr, n, detail::kMaxGaussOrder) <= target) oa = n;
    for (int n = 1; n <= detail::kMaxGaussOrder && ob == 0; ++n)
        if (far_field_error_bound(pr, oa, n) <= 2.0 * target) ob = n;
    if (oa == 0 || ob == 0) return -1.0;
    return polygon_to_polygon_quadrature(a, b, oa, ob);
}

double point_segment_distance(const Vec3& x, const Vec3& p, const Vec3& q) {
    const Vec3 d = q - p;
    const double len2 = d.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((x - p).dot(d) / len2, 0.0, 1.0) : 0.0;
    return (x - (p + t * d)).norm();
}

// F_ab = 1/A_a ∫_a F_{dA→b}(x) dA by a Gauss rule on a, when a lies in front of b and its
// circumradius is ≤ 1/4 of the distance from its centroid to b's plane and to the edges of b
// clipped by a's plane (the integrand is analytic on a); else −1.
double small_polygon_path(const Polygon& a, const Plane& pa, const Polygon& b, const Plane& pb,
                          double eps) {
    for (const Vec3& v : a.vertices)
        if (pb.signed_distance(v) < -eps) return -1.0;
    const Vec3 ca = centroid(a);
    double ra = 0.0;
    for (const Vec3& v : a.vertices) ra = std::max(ra, (v - ca).norm());
    double dist = std::abs(pb.signed_distance(ca));
    if (!(4.0 * ra <= dist)) return -1.0;
    const Polygon bc = clip_to_front(b, pa, eps);
    if (bc.size() < 3) return 0.0;
    for (std::size_t k = 0; k < bc.size(); ++k)
        dist = std::min(dist, point_segment_distance(ca, bc[k], bc[(k + 1) % bc.size()]));
    if (!(4.0 * ra <= dist)) return -1.0;
    // F_{dA→b} ≤ 1: the Gauss error is ≲ C ϱ^(−2n) with ϱ from q = R_a/dist (docs/analytic.md).
    const int n = detail::gauss_order_for(1.0, ra / dist, 1e-16, detail::kMaxGaussOrder);
    if (n == 0) return -1.0;
    const PolygonRule rule = polygon_rule(a, n);
    const Vec3 na = pa.n;
    double sum = 0.0, wsum = 0.0;
    for (std::size_t k = 0; k < rule.points.size(); ++k) {
        sum += rule.weights[k] * point_to_polygon(rule.points[k], na, bc);
        wsum += rule.weights[k];
    }
    return sum / wsum;
}

// ---------------------------------------------------------------------------------------------
// Edge pair integrals I = ∫_0^A ∫_0^B ln(r/ℓ) dt ds, r = |P + s u − Q − t v|, u, v unit.

// Second antiderivative of ln(sqrt(x² + h²)/ℓ) in x (up to terms linear in x, which cancel in
// the second differences below): ¼(x² − h²) ln((x² + h²)/ℓ²) − ¾x² + h x atan(x/h).
inline double second_antiderivative(double x, double h, double ln_l2) {
    const double r2 = x * x + h * h;
    double v = -0.75 * x * x;
    if (r2 > 0.0) v += 0.25 * (x * x - h * h) * (std::log(r2) - ln_l2);
    if (h > 0.0) v += h * x * std::copysign(detail::atan_nonneg(std::abs(x) / h), x);
    return v;
}

// Parallel (or anti-parallel, or collinear) edges: closed form by second differences.
double edge_pair_parallel(const Vec3& P, const Vec3& u, double A, const Vec3& Q, const Vec3& v,
                          double B, double ln_l2) {
    const Vec3 w = P - Q;
    const double c0 = w.dot(u);
    const double h = w.cross(u).norm();
    if (u.dot(v) > 0.0) {
        return second_antiderivative(c0 + A, h, ln_l2) - second_antiderivative(c0, h, ln_l2) -
               second_antiderivative(c0 + A - B, h, ln_l2) +
               second_antiderivative(c0 - B, h, ln_l2);
    }
    return second_antiderivative(c0 + A + B, h, ln_l2) - second_antiderivative(c0 + B, h, ln_l2) -
           second_antiderivative(c0 + A, h, ln_l2) + second_antiderivative(c0, h, ln_l2);
}

// ∫_0^B ln(|p − Q − t v|/ℓ) dt in closed form: [τ ln r − τ + h atan(τ/h)] over τ ∈ [−a, B − a].
inline double inner_integral(const Vec3& p, const Vec3& Q, const Vec3& v, double B, double ln_l) {
    const Vec3 w = p - Q;
    const double a = w.dot(v);
    const double h = w.cross(v).norm();
    const double t0 = -a, t1 = B - a;
    const double r0sq = w.squaredNorm();
    const double r1sq = t1 * t1 + h * h;
    double val = -B;
    if (r1sq > 0.0) val += t1 * (0.5 * std::log(r1sq) - ln_l);
    if (r0sq > 0.0) val -= t0 * (0.5 * std::log(r0sq) - ln_l);
    if (h > 0.0) val += h * detail::atan2_upper(h * B, h * h + t0 * t1);
    return val;
}

// Gauss–Kronrod 15/7 (QUADPACK qk15) on [-1, 1].
constexpr std::array<double, 8> kXgk = {
    0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
    0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
    0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
    0.207784955007898467600689403773245, 0.000000000000000000000000000000000};
constexpr std::array<double, 8> kWgk = {
    0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
    0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
    0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
    0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
constexpr std::array<double, 4> kWg = {
    0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
    0.381830050505118944950369775488975, 0.417959183673469387755102040816327};

struct Panel {
    double lo, hi, value, error;
};

template <class F>
Panel gk15(const F& f, double lo, double hi) {
    const double c = 0.5 * (lo + hi), hw = 0.5 * (hi - lo);
    const double fc = f(c);
    double f1[7], f2[7];
    double k = fc * kWgk[7], g = fc * kWg[3];
    for (int j = 0; j < 7; ++j) {
        const double dx = hw * kXgk[static_cast<std::size_t>(j)];
        f1[j] = f(c - dx);
        f2[j] = f(c + dx);
        k += kWgk[static_cast<std::size_t>(j)] * (f1[j] + f2[j]);
        if (j % 2 == 1) g += kWg[static_cast<std::size_t>(j / 2)] * (f1[j] + f2[j]);
    }
    // QUADPACK's error estimate: |K15 − G7| is the error of G7; scaled by the variation of f
    // about its mean (resasc) it estimates the error of K15 without gross pessimism.
    const double mean = 0.5 * k;
    double resasc = kWgk[7] * std::abs(fc - mean);
    for (int j = 0; j < 7; ++j)
        resasc +=
            kWgk[static_cast<std::size_t>(j)] * (std::abs(f1[j] - mean) + std::abs(f2[j] - mean));
    resasc *= std::abs(hw);
    double err = std::abs((k - g) * hw);
    if (resasc != 0.0 && err != 0.0)
        err = resasc * std::min(1.0, std::pow(200.0 * err / resasc, 1.5));
    return {lo, hi, k * hw, err};
}

// Globally adaptive Gauss–Kronrod over [0, L] with the given breakpoints (sorted, inside).
template <class F>
double integrate_adaptive(const F& f, const std::vector<double>& cuts, double tol) {
    std::vector<Panel> panels;
    panels.reserve(64);
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k)
        if (cuts[k + 1] > cuts[k]) panels.push_back(gk15(f, cuts[k], cuts[k + 1]));
    auto worse = [](const Panel& x, const Panel& y) { return x.error < y.error; };
    std::make_heap(panels.begin(), panels.end(), worse);
    double total_err = 0.0;
    for (const Panel& p : panels) total_err += p.error;
    for (int it = 0; it < 400 && total_err > tol; ++it) {
        std::pop_heap(panels.begin(), panels.end(), worse);
        const Panel p = panels.back();
        panels.pop_back();
        const double mid = 0.5 * (p.lo + p.hi);
        if (!(mid > p.lo && mid < p.hi)) {  // cannot split further: keep it
            panels.push_back({p.lo, p.hi, p.value, 0.0});
            std::push_heap(panels.begin(), panels.end(), worse);
            total_err -= p.error;
            continue;
        }
        const Panel l = gk15(f, p.lo, mid), r = gk15(f, mid, p.hi);
        total_err += l.error + r.error - p.error;
        panels.push_back(l);
        std::push_heap(panels.begin(), panels.end(), worse);
        panels.push_back(r);
        std::push_heap(panels.begin(), panels.end(), worse);
    }
    // Sum in position order so that the result does not depend on the heap's history.
    std::sort(panels.begin(), panels.end(),
              [](const Panel& x, const Panel& y) { return x.lo < y.lo; });
    double sum = 0.0;
    for (const Panel& p : panels) sum += p.value;
    return sum;
}

// Non-parallel edges: closed-form inner integral, adaptive outer integral with breakpoints at
// the closest point of the two lines and at the projections of the other edge's endpoints.
double edge_pair_numeric(const Vec3& P, const Vec3& u, double A, const Vec3& Q, const Vec3& v,
                         double B, double ln_l, double tol) {
    std::vector<double> cuts;
    cuts.reserve(6);
    cuts.push_back(0.0);
    auto add_cut = [&](double s) {
        if (s > 1e-12 * A && s < A * (1.0 - 1e-12)) cuts.push_back(s);
    };
    add_cut((Q - P).dot(u));
    add_cut((Q + B * v - P).dot(u));
    const Vec3 w0 = P - Q;
    const double b = u.dot(v), d = u.dot(w0), e = v.dot(w0);
    const double denom = 1.0 - b * b;
    if (denom > 0.0) add_cut((b * e - d) / denom);
    cuts.push_back(A);
    std::sort(cuts.begin(), cuts.end());
    const Vec3 q = Q;
    auto f = [&](double s) { return inner_integral(P + s * u, q, v, B, ln_l); };
    return integrate_adaptive(f, cuts, tol);
}

// Edge list of a polygon: start points, unit directions and lengths (zero edges dropped).
struct Edges {
    std::vector<Vec3> start, dir;
    std::vector<double> length;
};

Edges edges_of(const Polygon& p) {
    Edges e;
    const std::size_t n = p.size();
    for (std::size_t k = 0; k < n; ++k) {
        const Vec3 d = p[(k + 1) % n] - p[k];
        const double len = d.norm();
        if (len == 0.0) continue;
        e.start.push_back(p[k]);
        e.dir.push_back(d / len);
        e.length.push_back(len);
    }
    return e;
}

}  // namespace

double point_to_polygon(const Vec3& x, const Vec3& n, const Polygon& p) {
    if (p.size() < 3) return 0.0;
    const Plane pp = plane_of(p);
    if (!(pp.signed_distance(x) > 0.0)) return 0.0;  // behind p or in its plane
    const double scale = diameter(p) + (x - p[0]).norm();
    const Plane element{n, n.dot(x)};
    const Polygon c = clip_to_front(p, element, 1e-14 * scale);
    if (c.size() < 3) return 0.0;
    double sum = 0.0;
    const std::size_t m = c.size();
    for (std::size_t k = 0; k < m; ++k) {
        const Vec3 r0 = c[k] - x, r1 = c[(k + 1) % m] - x;
        const Vec3 cr = r0.cross(r1);
        const double len = cr.norm();
        if (len == 0.0) continue;
        const double gamma = detail::atan2_upper(len, r0.dot(r1));
        sum += gamma * n.dot(cr) / len;
    }
    // Seen from x the front of p runs clockwise about the direction to p: the sum is negative.
    return std::max(0.0, -sum / kTwoPi);
}

double polygon_to_polygon(const Polygon& a, const Polygon& b) {
    return detail::polygon_to_polygon_contour(a, b, true);
}

double detail::polygon_to_polygon_contour(const Polygon& a, const Polygon& b,
                                          bool allow_far_field) {
    if (a.size() < 3 || b.size() < 3) return 0.0;
    const double area_a = area(a);
    if (!(area_a > 0.0) || !(area(b) > 0.0)) return 0.0;
    const Plane pa = plane_of(a), pb = plane_of(b);
    const double scale = pair_scale(a, b);
    const double eps = 1e-12 * scale;
    // Facing away, behind each other or coplanar.
    if (nothing_in_front(b, pa, eps) || nothing_in_front(a, pb, eps)) return 0.0;
    // Well separated and fully in front of each other: the contour terms would cancel
    // catastrophically (they grow like d² ln d, the result like 1/d²); a Gauss rule whose
    // a-priori error bound is below 1e-15 is both exact to rounding and faster.
    if (allow_far_field && far_field_ok(a, pa, b, pb, eps)) {
        const double f = far_field_exact(a, b, area_a);
        if (f >= 0.0) return f;
    }
    // A polygon small compared with its distance to the other's edges and plane: integrate
    // Lambert's formula over it (smooth there) instead of the contour terms, which would lose
    // about L_b/L_a digits (reciprocity gives F_ab when b is the small one).
    if (allow_far_field) {
        const double f = small_polygon_path(a, pa, b, pb, eps);
        if (f >= 0.0) return f;
        const double g = small_polygon_path(b, pb, a, pa, eps);
        if (g >= 0.0) return g * area(b) / area_a;
    }
    const Polygon ac = clip_to_front(a, pb, eps);
    const Polygon bc = clip_to_front(b, pa, eps);
    if (ac.size() < 3 || bc.size() < 3) return 0.0;
    const Edges ea = edges_of(ac), eb = edges_of(bc);

    // ln of a reference length: the contour integrals of a constant vanish, so any ℓ gives the
    // same result; one of the size of the pair keeps the terms small (less cancellation).
    const double ln_l = std::log(scale);
    const double ln_l2 = 2.0 * ln_l;
    std::size_t active = 0;
    for (const Vec3& u : ea.dir)
        for (const Vec3& v : eb.dir)
            if (std::abs(u.dot(v)) > 1e-15) ++active;
    if (active == 0) return 0.0;
    const double tol_total = 1e-14 * kTwoPi * area_a;

    double sum = 0.0;
    for (std::size_t k = 0; k < ea.dir.size(); ++k) {
        const Vec3& P = ea.start[k];
        const Vec3& u = ea.dir[k];
        const double A = ea.length[k];
        for (std::size_t l = 0; l < eb.dir.size(); ++l) {
            const Vec3& v = eb.dir[l];
            const double dot = u.dot(v);
            if (std::abs(dot) <= 1e-15) continue;
            const double B = eb.length[l];
            const Vec3& Q = eb.start[l];
            double I;
            if (u.cross(v).norm() <= 1e-13) {
                I = edge_pair_parallel(P, u, A, Q, v, B, ln_l2);
            } else {
                const double tol =
                    std::max(tol_total / static_cast<double>(active), 1e-16 * A * B) /
                    std::abs(dot);
                I = edge_pair_numeric(P, u, A, Q, v, B, ln_l, tol);
            }
            sum += dot * I;
        }
    }
    return sum / (kTwoPi * area_a);
}

}  // namespace formfactor
