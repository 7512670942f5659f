#pragma once
// Internals of the analytic method shared by its source files (not public API).

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/types.h"
#include "formfactor/kernels/analytic.h"

namespace formfactor::detail {

/// The calibrated constant C of the far-field error model C ϱ^(−2n) (docs/analytic.md).
inline constexpr double kGaussConstantPublic = 3.0;

/// Largest Gauss–Legendre order tabulated.
inline constexpr int kMaxGaussOrder = 24;

/// Gauss–Legendre nodes and weights on [0, 1] (weights sum to 1).
struct GaussRule {
    std::vector<double> x, w;
};
const GaussRule& gauss_legendre01(int n);
/// Gauss–Jacobi nodes and weights on [0, 1] for the weight ξ (weights sum to 1/2).
const GaussRule& gauss_jacobi01(int n);

/// A polygon rule as flat arrays (structure of arrays), borrowed.
struct RuleView {
    const double* x;
    const double* y;
    const double* z;
    const double* w;
    int count;
};

/// Points of polygon rules appended one after another (structure of arrays).
struct RulePoints {
    std::vector<double> x, y, z, w;
    void clear() {
        x.clear();
        y.clear();
        z.clear();
        w.clear();
    }
    std::size_t size() const { return x.size(); }
    RuleView view(std::size_t first, std::size_t count) const {
        return {x.data() + first, y.data() + first, z.data() + first, w.data() + first,
                static_cast<int>(count)};
    }
};

/// How polygon_rule() lays its points: nothing (fewer than 3 vertices), the collapsed square on
/// a triangle, the tensor rule on a parallelogram, or the triangles of triangulate().
enum class RuleShape : std::uint8_t { kEmpty, kTriangle, kParallelogram, kTriangles };
RuleShape rule_shape(const Polygon& p);

/// Appends polygon_rule(p, order)'s points and weights to `out`, bit for bit, without building
/// it: shape = rule_shape(p) and, for kTriangles, tris = triangulate(p) flattened (tri_count
/// triangles of 3 vertex indices), both computed once per polygon by the caller.
void append_rule(const Polygon& p, RuleShape shape, const int* tris, std::size_t tri_count,
                 int order, RulePoints& out);

/// Owning structure-of-arrays copy of a PolygonRule.
struct RuleSoA {
    std::vector<double> x, y, z, w;
    explicit RuleSoA(const PolygonRule& r) {
        for (std::size_t k = 0; k < r.points.size(); ++k) {
            x.push_back(r.points[k].x());
            y.push_back(r.points[k].y());
            z.push_back(r.points[k].z());
            w.push_back(r.weights[k]);
        }
    }
    RuleView view() const {
        return {x.data(), y.data(), z.data(), w.data(), static_cast<int>(x.size())};
    }
};

/// Σ_i Σ_j w_i w_j cosθ_a cosθ_b/(π r²) over the two rules (= A_a F_ab when the rules are fine
/// enough); na, nb the unit front normals; origin a point near the pair (for conditioning).
double far_field_kernel_sum(const RuleView& ra, const Vec3& na, const RuleView& rb, const Vec3& nb,
                            const Vec3& origin);

/// polygon_to_polygon; with allow_far_field false always by the double contour integral (for
/// tests and calibration).
double polygon_to_polygon_contour(const Polygon& a, const Polygon& b, bool allow_far_field);

/// Relative error factor of an order-n Gauss rule over a polygon of circumradius R seen from a
/// point at distance D ≥ R from its centroid, q = R/D < 1 (see docs/analytic.md).
double gauss_factor(int n, double q);

/// Smallest order n ≤ max_order with pref · gauss_factor(n, q) ≤ target, 0 when there is none.
int gauss_order_for(double pref, double q, double target, int max_order);

/// gauss_order_for without transcendental functions (one square root): the hot-path version.
inline int gauss_order_for_fast(double pref, double q, double target, int max_order);

/// The far-field pairs of one row, batched by the order of the row's own rule: the points of
/// every receiver of a batch are laid out flat (structure of arrays, relative to the row
/// patch's centroid) so that the kernel loop runs over them without padding or reductions.
class FarFieldBatch {
  public:
    void reset();
    /// Queues receiver j (unit normal nj, centroid cj) for the row rule of `order`; fill(points)
    /// appends j's rule to the batch's RulePoints.
    template <class Fill>
    void add(int order, std::size_t j, const Vec3& nj, const Vec3& cj, const Fill& fill) {
        RulePoints& pts = points_[order];
        const std::size_t first = pts.size();
        fill(pts);
        queued_[order].push_back({j, first, pts.size() - first, nj, cj});
    }
    /// Computes every queued pair: row_rule(order) gives the row patch's rule, ni its normal,
    /// ci its centroid, inv_area 1/A_i; emit(j, F_ij) receives each result, in queue order.
    template <class RowRule, class Emit>
    void run(const RowRule& row_rule, const Vec3& ni, const Vec3& ci, double inv_area,
             const Emit& emit);

  private:
    struct Item {
        std::size_t j, first, count;  // the rule: points [first, first + count) of its order
        Vec3 n, c;
    };
    std::vector<Item> queued_[kMaxGaussOrder + 1];
    RulePoints points_[kMaxGaussOrder + 1];
    // Flat point data of one tile of receivers.
    std::vector<double> x_, y_, z_, nx_, ny_, nz_, aw_, acc_;
    std::vector<int> ends_;
    void flush(const RuleView& ri, const Vec3& ni, double inv_area, std::size_t first,
               std::size_t last, const std::vector<Item>& items, const RulePoints& points,
               std::vector<double>& results);
    std::vector<double> results_;
};

/// Σ over the row rule's points of w_i β_i / r⁴ for every flat point (the vectorised core).
void far_field_accumulate(const RuleView& ri, const double* x, const double* y, const double* z,
                          const double* nx, const double* ny, const double* nz, double* acc,
                          int count);

inline int gauss_order_for_fast(double pref, double q, double target, int max_order) {
    if (!(q < 1.0) || !(q > 0.0)) return q == 0.0 ? 1 : 0;
    const double inv_rho = q / (1.0 + std::sqrt(1.0 - q * q));
    const double r2 = inv_rho * inv_rho;
    double g = kGaussConstantPublic * pref * r2;
    int n = 1;
    while (g > target && n < max_order) {
        g *= r2;
        ++n;
    }
    return g <= target ? n : 0;
}

template <class RowRule, class Emit>
void FarFieldBatch::run(const RowRule& row_rule, const Vec3& ni, const Vec3& ci, double inv_area,
                        const Emit& emit) {
    for (int order = 1; order <= kMaxGaussOrder; ++order) {
        const std::vector<Item>& items = queued_[order];
        if (items.empty()) continue;
        const RuleView ri = row_rule(order);
        results_.assign(items.size(), 0.0);
        // Tiles of about kTilePoints points keep the flat arrays in L1.
        constexpr int kTilePoints = 384;
        std::size_t first = 0;
        int points = 0;
        for (std::size_t k = 0; k < items.size(); ++k) {
            points += static_cast<int>(items[k].count);
            if (points >= kTilePoints || k + 1 == items.size()) {
                flush(ri, ni, inv_area, first, k + 1, items, points_[order], results_);
                first = k + 1;
                points = 0;
            }
        }
        (void)ci;
        for (std::size_t k = 0; k < items.size(); ++k) emit(items[k].j, results_[k]);
    }
}

}  // namespace formfactor::detail
