// Far-field path of the analytic method: tensor Gauss rules on both polygons applied to the
// smooth kernel cosθ_a cosθ_b/(π r²), and the a-priori error bound that chooses their order.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>

#include "formfactor/methods/analytic.h"
#include "methods/analytic_internal.h"

namespace formfactor {

namespace detail {

namespace {

// Calibrated constant of the error model (docs/analytic.md).
constexpr double kGaussConstant = 1.0;

// Gauss–Legendre nodes and weights on [0, 1] by Newton's method on P_n.
GaussRule compute_gauss(int n) {
    GaussRule r;
    r.x.resize(static_cast<std::size_t>(n));
    r.w.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double dp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = 0.0;
            for (int k = 1; k <= n; ++k) {
                const double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p2) / k;
            }
            dp = n * (z * p0 - p1) / (z * z - 1.0);
            const double dz = p0 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) break;
        }
        // Recompute the derivative at the converged node.
        double p0 = 1.0, p1 = 0.0;
        for (int k = 1; k <= n; ++k) {
            const double p2 = p1;
            p1 = p0;
            p0 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p2) / k;
        }
        dp = n * (z * p0 - p1) / (z * z - 1.0);
        const double w = 2.0 / ((1.0 - z * z) * dp * dp);
        r.x[static_cast<std::size_t>(i)] = 0.5 * (1.0 - z);
        r.w[static_cast<std::size_t>(i)] = 0.5 * w;
    }
    return r;
}

}  // namespace

const GaussRule& gauss_legendre01(int n) {
    static const std::array<GaussRule, kMaxGaussOrder + 1> rules = [] {
        std::array<GaussRule, kMaxGaussOrder + 1> r;
        for (int n1 = 1; n1 <= kMaxGaussOrder; ++n1)
            r[static_cast<std::size_t>(n1)] = compute_gauss(n1);
        return r;
    }();
    FF_ASSERT(n >= 1 && n <= kMaxGaussOrder);
    return rules[static_cast<std::size_t>(n)];
}

namespace {

void triangle_rule(const Vec3& A, const Vec3& B, const Vec3& C, int n, PolygonRule& out) {
    // Collapsed (Duffy) square: x = A + ξ(B − A) + ξη(C − B), dA = 2|T| ξ dξ dη.
    const GaussRule& g = gauss_legendre01(n);
    const double two_area = (B - A).cross(C - B).norm();
    for (int i = 0; i < n; ++i) {
        const double xi = g.x[static_cast<std::size_t>(i)];
        for (int j = 0; j < n; ++j) {
            const double eta = g.x[static_cast<std::size_t>(j)];
            out.points.push_back(A + xi * (B - A) + xi * eta * (C - B));
            out.weights.push_back(two_area * xi * g.w[static_cast<std::size_t>(i)] *
                                  g.w[static_cast<std::size_t>(j)]);
        }
    }
}

bool convex_quad(const Polygon& p, const Vec3& nrm) {
    for (std::size_t k = 0; k < 4; ++k) {
        const Vec3 e0 = p[(k + 1) % 4] - p[k], e1 = p[(k + 2) % 4] - p[(k + 1) % 4];
        if (!(e0.cross(e1).dot(nrm) > 0.0)) return false;
    }
    return true;
}

}  // namespace

}  // namespace detail

PolygonRule polygon_rule(const Polygon& p, int order) {
    using namespace detail;
    PolygonRule out;
    const int n = std::clamp(order, 1, kMaxGaussOrder);
    if (p.size() < 3) return out;
    if (p.size() == 3) {
        triangle_rule(p[0], p[1], p[2], n, out);
        return out;
    }
    const Vec3 nrm = normal(p);
    if (p.size() == 4 && convex_quad(p, nrm)) {
        // Bilinear map of the unit square; its Jacobian is linear for a planar quad.
        const GaussRule& g = gauss_legendre01(n);
        for (int i = 0; i < n; ++i) {
            const double s = g.x[static_cast<std::size_t>(i)];
            for (int j = 0; j < n; ++j) {
                const double t = g.x[static_cast<std::size_t>(j)];
                const Vec3 x = (1 - s) * (1 - t) * p[0] + s * (1 - t) * p[1] + s * t * p[2] +
                               (1 - s) * t * p[3];
                const Vec3 ds = (1 - t) * (p[1] - p[0]) + t * (p[2] - p[3]);
                const Vec3 dt = (1 - s) * (p[3] - p[0]) + s * (p[2] - p[1]);
                out.points.push_back(x);
                out.weights.push_back(ds.cross(dt).norm() * g.w[static_cast<std::size_t>(i)] *
                                      g.w[static_cast<std::size_t>(j)]);
            }
        }
        return out;
    }
    for (const auto& t : triangulate(p))
        triangle_rule(p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                      p[static_cast<std::size_t>(t[2])], n, out);
    return out;
}

namespace detail {

double far_field_kernel_sum(const RuleView& ra, const Vec3& na, const RuleView& rb, const Vec3& nb,
                            const Vec3& origin) {
    // cosθ_a cosθ_b / (π r²) = (n_a·(y − x)) (n_b·(x − y)) / (π r⁴); for planar polygons
    // n_a·x is constant over a, so the numerator factors into α_j = n_a·y_j − n_a·x and
    // β_i = n_b·x_i − n_b·y: only r² is computed per point pair.
    const double da = na.dot(Vec3(ra.x[0], ra.y[0], ra.z[0]) - origin);
    const double db = nb.dot(Vec3(rb.x[0], rb.y[0], rb.z[0]) - origin);
    thread_local std::vector<double> buffer;
    if (buffer.size() < 4 * static_cast<std::size_t>(rb.count))
        buffer.resize(4 * static_cast<std::size_t>(rb.count));
    double* __restrict bx = buffer.data();
    double* __restrict by = bx + rb.count;
    double* __restrict bz = by + rb.count;
    double* __restrict bw = bz + rb.count;
    const double ox = origin.x(), oy = origin.y(), oz = origin.z();
    for (int j = 0; j < rb.count; ++j) {
        bx[j] = rb.x[j] - ox;
        by[j] = rb.y[j] - oy;
        bz[j] = rb.z[j] - oz;
        const double alpha = na.x() * bx[j] + na.y() * by[j] + na.z() * bz[j] - da;
        bw[j] = rb.w[j] * alpha;
    }
    double total = 0.0;
    for (int i = 0; i < ra.count; ++i) {
        const double xx = ra.x[i] - ox, xy = ra.y[i] - oy, xz = ra.z[i] - oz;
        const double beta = nb.x() * xx + nb.y() * xy + nb.z() * xz - db;
        double acc = 0.0;
        for (int j = 0; j < rb.count; ++j) {
            const double dx = xx - bx[j], dy = xy - by[j], dz = xz - bz[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            acc += bw[j] / (r2 * r2);
        }
        total += ra.w[i] * beta * acc;
    }
    return total * kInvPi;
}

}  // namespace detail

double polygon_to_polygon_quadrature(const Polygon& a, const Polygon& b, int order_a, int order_b) {
    const double area_a = area(a);
    if (!(area_a > 0.0)) return 0.0;
    const PolygonRule ra = polygon_rule(a, order_a), rb = polygon_rule(b, order_b);
    detail::RuleSoA sa(ra), sb(rb);
    return detail::far_field_kernel_sum(sa.view(), normal(a), sb.view(), normal(b), centroid(a)) /
           area_a;
}

namespace detail {

double gauss_factor(int n, double q) {
    if (!(q < 1.0)) return std::numeric_limits<double>::infinity();
    // Bernstein ellipse through the nearest complex singularity of 1/r² at distance 1/q (in
    // units of the half-width): ϱ = 1/q + sqrt(1/q² − 1); the Gauss error decays as ϱ^(−2n).
    const double rho = (1.0 + std::sqrt(1.0 - q * q)) / q;
    return kGaussConstant * std::pow(rho, -2.0 * n);
}

}  // namespace detail

double far_field_error_bound(const FarFieldPair& pair, int order_a, int order_b) {
    const double dmin = pair.distance - pair.radius_a - pair.radius_b;
    if (!(dmin > 0.0)) return std::numeric_limits<double>::infinity();
    const double pref = std::max(pair.area_a, pair.area_b) * kInvPi / (dmin * dmin);
    return pref * (detail::gauss_factor(order_a, pair.radius_a / (pair.distance - pair.radius_b)) +
                   detail::gauss_factor(order_b, pair.radius_b / (pair.distance - pair.radius_a)));
}

}  // namespace formfactor
