#pragma once
// Internals of the analytic method shared by its source files (not public API).

#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/types.h"
#include "formfactor/methods/analytic.h"

namespace formfactor::detail {

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

}  // namespace formfactor::detail
