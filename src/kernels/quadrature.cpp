// Far-field path of the analytic method: tensor Gauss rules on both polygons applied to the
// smooth kernel cosθ_a cosθ_b/(π r²), and the a-priori error bound that chooses their order.

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>

#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"

namespace formfactor {

namespace detail {

namespace {

// Calibrated constant of the error model (docs/analytic.md).
constexpr double kGaussConstant = kGaussConstantPublic;

// Gauss–Jacobi nodes and weights for the weight (1 − x)^α (1 + x)^β on [−1, 1], mapped to [0, 1]
// (Golub–Welsch: eigenvalues of the Jacobi matrix). Weights sum to ∫_0^1 of the mapped weight.
GaussRule compute_gauss_jacobi(int n, double alpha, double beta) {
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n, n);
    const double ab = alpha + beta;
    for (int k = 0; k < n; ++k) {
        const double t = 2.0 * k + ab;
        J(k, k) = (k == 0 && ab == 0.0) ? (beta - alpha) / (ab + 2.0)
                                        : (beta * beta - alpha * alpha) / (t * (t + 2.0));
        if (k + 1 < n) {
            const double m = k + 1.0, tm = 2.0 * m + ab;
            const double b2 =
                4.0 * m * (m + alpha) * (m + beta) * (m + ab) / (tm * tm * (tm + 1.0) * (tm - 1.0));
            J(k, k + 1) = J(k + 1, k) = std::sqrt(b2);
        }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(J);
    const double mu0 = std::pow(2.0, ab + 1.0) * std::tgamma(alpha + 1.0) *
                       std::tgamma(beta + 1.0) / std::tgamma(ab + 2.0);
    GaussRule r;
    for (int k = 0; k < n; ++k) {
        const double v0 = es.eigenvectors()(0, k);
        r.x.push_back(0.5 * (es.eigenvalues()(k) + 1.0));
        r.w.push_back(mu0 * v0 * v0 * std::pow(0.5, ab + 1.0));
    }
    return r;
}

}  // namespace

const GaussRule& gauss_legendre01(int n) {
    static const std::array<GaussRule, kMaxGaussOrder + 1> rules = [] {
        std::array<GaussRule, kMaxGaussOrder + 1> r;
        for (int n1 = 1; n1 <= kMaxGaussOrder; ++n1)
            r[static_cast<std::size_t>(n1)] = compute_gauss_jacobi(n1, 0.0, 0.0);
        return r;
    }();
    FF_ASSERT(n >= 1 && n <= kMaxGaussOrder);
    return rules[static_cast<std::size_t>(n)];
}

const GaussRule& gauss_jacobi01(int n) {
    static const std::array<GaussRule, kMaxGaussOrder + 1> rules = [] {
        std::array<GaussRule, kMaxGaussOrder + 1> r;
        for (int m = 1; m <= kMaxGaussOrder; ++m)
            r[static_cast<std::size_t>(m)] = compute_gauss_jacobi(m, 0.0, 1.0);
        return r;
    }();
    FF_ASSERT(n >= 1 && n <= kMaxGaussOrder);
    return rules[static_cast<std::size_t>(n)];
}

namespace {

// The points of polygon_rule() on triangle ABC, emit(x, w) each: the collapsed (Duffy) square
// x = A + ξ(B − A) + ξη(C − B), dA = 2|T| ξ dξ dη; Gauss–Jacobi with weight ξ in ξ keeps the
// rule exact for polynomials of degree 2n − 1.
template <class Emit>
void triangle_points(const Vec3& A, const Vec3& B, const Vec3& C, int n, const Emit& emit) {
    const GaussRule& gj = gauss_jacobi01(n);
    const GaussRule& g = gauss_legendre01(n);
    const Vec3 ab = B - A, bc = C - B;
    const double two_area = ab.cross(bc).norm();
    for (int i = 0; i < n; ++i) {
        const double xi = gj.x[static_cast<std::size_t>(i)];
        const Vec3 along = A + xi * ab;
        const double wi = two_area * gj.w[static_cast<std::size_t>(i)];
        for (int j = 0; j < n; ++j) {
            const double eta = g.x[static_cast<std::size_t>(j)];
            emit(along + xi * eta * bc, wi * g.w[static_cast<std::size_t>(j)]);
        }
    }
}

// ... on a parallelogram: the affine map of the unit square, constant Jacobian, so the tensor
// rule is exact for degree 2n − 1 (other quads are split into triangles, whose bilinear
// Jacobian would cost a degree). The bilinear form of the map, so that a quad within rounding
// of a parallelogram keeps its own corners.
template <class Emit>
void parallelogram_points(const Polygon& p, int n, const Emit& emit) {
    const GaussRule& g = gauss_legendre01(n);
    const Vec3 e01 = p[1] - p[0], e32 = p[2] - p[3], e03 = p[3] - p[0], e12 = p[2] - p[1];
    for (int i = 0; i < n; ++i) {
        const double s = g.x[static_cast<std::size_t>(i)];
        const double wi = g.w[static_cast<std::size_t>(i)];
        const Vec3 dt = (1 - s) * e03 + s * e12;
        for (int j = 0; j < n; ++j) {
            const double t = g.x[static_cast<std::size_t>(j)];
            const Vec3 x =
                (1 - s) * (1 - t) * p[0] + s * (1 - t) * p[1] + s * t * p[2] + (1 - s) * t * p[3];
            const Vec3 ds = (1 - t) * e01 + t * e32;
            emit(x, ds.cross(dt).norm() * wi * g.w[static_cast<std::size_t>(j)]);
        }
    }
}

template <class Emit>
void rule_points(const Polygon& p, RuleShape shape, const int* tris, std::size_t tri_count,
                 int order, const Emit& emit) {
    const int n = std::clamp(order, 1, kMaxGaussOrder);
    switch (shape) {
        case RuleShape::kEmpty:
            return;
        case RuleShape::kTriangle:
            triangle_points(p[0], p[1], p[2], n, emit);
            return;
        case RuleShape::kParallelogram:
            parallelogram_points(p, n, emit);
            return;
        case RuleShape::kTriangles:
            for (std::size_t t = 0; t < tri_count; ++t)
                triangle_points(p[static_cast<std::size_t>(tris[3 * t])],
                                p[static_cast<std::size_t>(tris[3 * t + 1])],
                                p[static_cast<std::size_t>(tris[3 * t + 2])], n, emit);
            return;
    }
}

}  // namespace

RuleShape rule_shape(const Polygon& p) {
    if (p.size() < 3) return RuleShape::kEmpty;
    if (p.size() == 3) return RuleShape::kTriangle;
    if (p.size() == 4 && convexity(p) == Convexity::strictly_convex &&
        (p[0] + p[2] - p[1] - p[3]).norm() <= 1e-12 * diameter(p))
        return RuleShape::kParallelogram;
    return RuleShape::kTriangles;
}

void append_rule(const Polygon& p, RuleShape shape, const int* tris, std::size_t tri_count,
                 int order, RulePoints& out) {
    const auto n = static_cast<std::size_t>(std::clamp(order, 1, kMaxGaussOrder));
    const std::size_t first = out.size();
    const std::size_t count =
        shape == RuleShape::kEmpty ? 0 : (shape == RuleShape::kTriangles ? tri_count : 1) * n * n;
    for (std::vector<double>* a : {&out.x, &out.y, &out.z, &out.w}) a->resize(first + count);
    double *x = out.x.data() + first, *y = out.y.data() + first, *z = out.z.data() + first,
           *w = out.w.data() + first;
    std::size_t k = 0;
    rule_points(p, shape, tris, tri_count, order, [&](const Vec3& q, double wq) {
        x[k] = q.x();
        y[k] = q.y();
        z[k] = q.z();
        w[k] = wq;
        ++k;
    });
    FF_ASSERT(k == count);
}

}  // namespace detail

PolygonRule polygon_rule(const Polygon& p, int order) {
    using namespace detail;
    PolygonRule out;
    const RuleShape shape = rule_shape(p);
    std::vector<int> flat;
    if (shape == RuleShape::kTriangles)
        for (const auto& t : triangulate(p)) flat.insert(flat.end(), t.begin(), t.end());
    rule_points(p, shape, flat.data(), flat.size() / 3, order, [&](const Vec3& x, double w) {
        out.points.push_back(x);
        out.weights.push_back(w);
    });
    return out;
}

namespace detail {

// The kernel sum is the hot loop of the method. Reductions use kLanes independent partial sums
// combined in a fixed order, so the compiler may vectorise them without reassociating (no
// -ffast-math) and the result is the same on every code path and thread count. target_clones
// builds AVX-512 and AVX2 variants chosen at load time (x86-64 with GCC only).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(FF_NO_CLONES)
#define FF_KERNEL_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define FF_KERNEL_CLONES
#endif

namespace {
constexpr int kLanes = 8;
}  // namespace

FF_KERNEL_CLONES
double far_field_kernel_sum(const RuleView& ra, const Vec3& na, const RuleView& rb, const Vec3& nb,
                            const Vec3& origin) {
    // cosθ_a cosθ_b / (π r²) = (n_a·(y − x)) (n_b·(x − y)) / (π r⁴); for planar polygons
    // n_a·x is constant over a, so the numerator factors into α_j = n_a·y_j − n_a·x and
    // β_i = n_b·x_i − n_b·y: only r² is computed per point pair.
    const double da = na.dot(Vec3(ra.x[0], ra.y[0], ra.z[0]) - origin);
    const double db = nb.dot(Vec3(rb.x[0], rb.y[0], rb.z[0]) - origin);
    const int nb_pad = (rb.count + kLanes - 1) / kLanes * kLanes;
    thread_local std::vector<double> buffer;
    if (buffer.size() < 4 * static_cast<std::size_t>(nb_pad))
        buffer.resize(4 * static_cast<std::size_t>(nb_pad));
    double* __restrict bx = buffer.data();
    double* __restrict by = bx + nb_pad;
    double* __restrict bz = by + nb_pad;
    double* __restrict bw = bz + nb_pad;
    const double ox = origin.x(), oy = origin.y(), oz = origin.z();
    for (int j = 0; j < nb_pad; ++j) {
        // Padding repeats the first point with weight 0 (r > 0, so it adds exactly 0).
        const int src = j < rb.count ? j : 0;
        bx[j] = rb.x[src] - ox;
        by[j] = rb.y[src] - oy;
        bz[j] = rb.z[src] - oz;
        const double alpha = na.x() * bx[j] + na.y() * by[j] + na.z() * bz[j] - da;
        bw[j] = j < rb.count ? rb.w[src] * alpha : 0.0;
    }
    double total = 0.0;
    for (int i = 0; i < ra.count; ++i) {
        const double xx = ra.x[i] - ox, xy = ra.y[i] - oy, xz = ra.z[i] - oz;
        const double beta = nb.x() * xx + nb.y() * xy + nb.z() * xz - db;
        double acc[kLanes] = {};
        for (int j = 0; j < nb_pad; j += kLanes) {
            for (int l = 0; l < kLanes; ++l) {
                const double dx = xx - bx[j + l], dy = xy - by[j + l], dz = xz - bz[j + l];
                const double r2 = dx * dx + dy * dy + dz * dz;
                acc[l] += bw[j + l] / (r2 * r2);
            }
        }
        const double sum =
            ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]));
        total += ra.w[i] * beta * sum;
    }
    return total * kInvPi;
}

FF_KERNEL_CLONES
void far_field_accumulate(const RuleView& ri, const double* __restrict x,
                          const double* __restrict y, const double* __restrict z,
                          const double* __restrict nx, const double* __restrict ny,
                          const double* __restrict nz, double* __restrict acc, int count) {
    // Points of the row rule are relative to the row patch's centroid like the flat points.
    // Two row points per pass share one division: a/b + c/d = (a d + c b)/(b d).
    int i = 0;
    for (; i + 1 < ri.count; i += 2) {
        const double x0 = ri.x[i], y0 = ri.y[i], z0 = ri.z[i], w0 = ri.w[i];
        const double x1 = ri.x[i + 1], y1 = ri.y[i + 1], z1 = ri.z[i + 1], w1 = ri.w[i + 1];
        for (int p = 0; p < count; ++p) {
            const double dx0 = x0 - x[p], dy0 = y0 - y[p], dz0 = z0 - z[p];
            const double dx1 = x1 - x[p], dy1 = y1 - y[p], dz1 = z1 - z[p];
            const double r0 = dx0 * dx0 + dy0 * dy0 + dz0 * dz0;
            const double r1 = dx1 * dx1 + dy1 * dy1 + dz1 * dz1;
            const double q0 = r0 * r0, q1 = r1 * r1;
            const double b0 = w0 * (nx[p] * dx0 + ny[p] * dy0 + nz[p] * dz0);
            const double b1 = w1 * (nx[p] * dx1 + ny[p] * dy1 + nz[p] * dz1);
            acc[p] += (b0 * q1 + b1 * q0) / (q0 * q1);
        }
    }
    for (; i < ri.count; ++i) {
        const double x0 = ri.x[i], y0 = ri.y[i], z0 = ri.z[i], w0 = ri.w[i];
        for (int p = 0; p < count; ++p) {
            const double dx0 = x0 - x[p], dy0 = y0 - y[p], dz0 = z0 - z[p];
            const double r0 = dx0 * dx0 + dy0 * dy0 + dz0 * dz0;
            const double b0 = w0 * (nx[p] * dx0 + ny[p] * dy0 + nz[p] * dz0);
            acc[p] += b0 / (r0 * r0);
        }
    }
}

void FarFieldBatch::reset() {
    for (auto& q : queued_) q.clear();
    for (auto& p : points_) p.clear();
}

void FarFieldBatch::flush(const RuleView& ri_abs, const Vec3& ni, double inv_area,
                          std::size_t first, std::size_t last, const std::vector<Item>& items,
                          const RulePoints& points, std::vector<double>& results) {
    // The row rule relative to its own centroid... the caller passes absolute points; we shift
    // everything to the first row point's frame instead (any origin on the row's plane works).
    const double ox = ri_abs.x[0], oy = ri_abs.y[0], oz = ri_abs.z[0];
    thread_local std::vector<double> rel;
    rel.resize(4 * static_cast<std::size_t>(ri_abs.count));
    double* rx = rel.data();
    double* ry = rx + ri_abs.count;
    double* rz = ry + ri_abs.count;
    double* rw = rz + ri_abs.count;
    for (int k = 0; k < ri_abs.count; ++k) {
        rx[k] = ri_abs.x[k] - ox;
        ry[k] = ri_abs.y[k] - oy;
        rz[k] = ri_abs.z[k] - oz;
        rw[k] = ri_abs.w[k];
    }
    const RuleView ri{rx, ry, rz, rw, ri_abs.count};
    int total = 0;
    for (std::size_t k = first; k < last; ++k) total += static_cast<int>(items[k].count);
    const auto sz = static_cast<std::size_t>(total);
    for (auto* v : {&x_, &y_, &z_, &nx_, &ny_, &nz_, &aw_, &acc_})
        if (v->size() < sz) v->resize(sz);
    int p = 0;
    for (std::size_t k = first; k < last; ++k) {
        const Item& it = items[k];
        const RuleView rule = points.view(it.first, it.count);
        // β = n_j·(x − y) in the kernel; α = n_i·(y − o) here (o on the row's plane).
        for (int m = 0; m < rule.count; ++m, ++p) {
            const double yx = rule.x[m] - ox, yy = rule.y[m] - oy, yz = rule.z[m] - oz;
            x_[p] = yx;
            y_[p] = yy;
            z_[p] = yz;
            nx_[p] = it.n.x();
            ny_[p] = it.n.y();
            nz_[p] = it.n.z();
            aw_[p] = rule.w[m] * (ni.x() * yx + ni.y() * yy + ni.z() * yz);
            acc_[p] = 0.0;
        }
    }
    far_field_accumulate(ri, x_.data(), y_.data(), z_.data(), nx_.data(), ny_.data(), nz_.data(),
                         acc_.data(), total);
    p = 0;
    for (std::size_t k = first; k < last; ++k) {
        double sum = 0.0;
        for (std::size_t m = 0; m < items[k].count; ++m, ++p) sum += aw_[p] * acc_[p];
        results[k] = sum * kInvPi * inv_area;
    }
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

int gauss_order_for(double pref, double q, double target, int max_order) {
    if (!(q < 1.0) || !(q > 0.0)) return q == 0.0 ? 1 : 0;
    const double need = std::log(kGaussConstant * pref / target);
    if (need <= 0.0) return 1;
    const double ln_rho = std::log((1.0 + std::sqrt(1.0 - q * q)) / q);
    const double n = std::ceil(need / (2.0 * ln_rho));
    if (!(n <= max_order)) return 0;
    return std::max(1, static_cast<int>(n));
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
