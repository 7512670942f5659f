#pragma once
// What the integration over a sender shares (hidden_integral.cpp, umbrae.cpp): the tensor
// Gauss–Legendre rules of a cell, the map of a convex sender piece from the unit square, a cell
// of that square, the umbra tests of a cell and the bound on F from its points that brackets it.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/analytic_internal.h"
#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

// The tensor Gauss–Legendre rules of a cell: the result is the highest order's, the larger
// difference between consecutive orders its error estimate.
constexpr int kLowOrder = 2, kMidOrder = 3, kHighOrder = 4;
// How much the difference of orders 2 and 3 is trusted on its own: the worst underestimate of
// a cell's error by that difference seen in the tests was 44× (orders 2 and 3 within 4e-8 of
// each other, 1.75e-6 from the integral), so a difference 50× below the target is taken as
// enough, with 50× the difference as the estimate.
constexpr double kAgreement = 50.0;
struct CellRules {
    const GaussRule& g2 = gauss_legendre01(kLowOrder);
    const GaussRule& g3 = gauss_legendre01(kMidOrder);
    const GaussRule& g4 = gauss_legendre01(kHighOrder);
};

// A convex piece of the sender mapped from the unit square: a quad by its bilinear map, a
// triangle by the collapsed (Duffy) map.
struct SenderMap {
    Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero(), p2 = Vec3::Zero(), p3 = Vec3::Zero();
    bool quad = false;
    double tri_j = 0;  // |(B − A) × (C − B)| for the triangle map
    Vec3 at(double u, double v) const {
        if (quad) return (1 - u) * (1 - v) * p0 + u * (1 - v) * p1 + u * v * p2 + (1 - u) * v * p3;
        return p0 + u * (p1 - p0) + u * v * (p2 - p1);
    }
    double jacobian(double u, double v) const {
        if (quad) {
            const Vec3 pu = (1 - v) * (p1 - p0) + v * (p2 - p3);
            const Vec3 pv = (1 - u) * (p3 - p0) + u * (p2 - p1);
            return pu.cross(pv).norm();
        }
        return tri_j * u;
    }
};

/// The tensor Gauss rule g × g of the given order (g's point count) over the cell [u0, u1] ×
/// [v0, v1] of the map m: Σ_i Σ_j w_i w_j J(u_i, v_j) f(u_i, v_j), u_i = u0 + (u1 − u0) x_i and
/// v_j likewise; unscaled (times du dv over the sender's area: the cell's part of (1/A_s) ∫ f
/// dA). The points come i outer, j inner, and are summed in that order: the k-th call of f is
/// point (k / order, k % order). The order is an argument so that a constant one unrolls.
template <class F>
double tensor_rule(const SenderMap& m, double u0, double u1, double v0, double v1,
                   const GaussRule& g, int order, F&& f) {
    const auto n = static_cast<std::size_t>(order);
    const double du = u1 - u0, dv = v1 - v0;
    double q = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j) {
            const double u = u0 + du * g.x[i], v = v0 + dv * g.x[j];
            const double val = f(u, v);
            q += g.w[i] * g.w[j] * m.jacobian(u, v) * val;
        }
    return q;
}

struct Cell {
    int map = 0;
    double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
    int level = 0;
    double value = 0, error = 0;
    bool bracketed = false;  // value and error from the cell's bracket; not integrated yet
    // Order 4 put off (hidden_integral()): orders 2 and 3 (unscaled), and the cell's candidates
    // at [cand_at, cand_at + cand_n) of the integration's list; cand_at < 0 when not put off.
    double q2 = 0, q3 = 0;
    int cand_at = -1, cand_n = 0;
};

/// A lower bound on the distance between the planar convex polygons a[0, na) and b[0, nb)
/// (exact when they do not intersect; 0 when they meet) (cell_bounds.cpp).
double polygon_distance(const Vec3* a, int na, const Vec3* b, int nb);

/// An upper bound on F(x → r) over the points x of the convex cell poly[0, np) in the sender's
/// plane (unit normal ns), from the heights of each above the other's plane and their distance:
/// F = (1/π) ∫_r cos θ_x cos θ_r / d² dA with d ≥ d_min, cos θ_x ≤ h_r / d_min (h_r the
/// receiver's largest height above the sender's plane), cos θ_r ≤ h_x / d_min (h_x the cell's
/// largest above r's plane); at most 1, and 1 where the cell touches r. A result above `limit`
/// may be less than the bound (the callers want it only when it is at most `limit`).
double point_factor_bound(const Vec3* poly, int np, const Vec3& ns, const Receiver& rc,
                          double limit = INFINITY);

/// What the cell [u0, u1] × [v0, v1] of the map m (corners poly[0, np), in the sender's plane,
/// unit normal nx) sees of the receiver past the umbrae of the candidates (umbrae.cpp). ok:
/// some occluder has an umbra from every corner; hidden: the umbrae cover the receiver, no point
/// of the cell sees any of it; else `bound` bounds the cell's visible part (1/A_s) ∫_cell
/// F(x → r) dA_x from above by what the umbrae leave of r (orders 2 and 3 of that smooth
/// integrand, plus kAgreement times their difference), scaled as the cell's rules are (`scale`:
/// the cell's du dv over the sender's area); left once above give_up (none when it is NaN).
struct CellUmbra {
    bool ok = false, hidden = false;
    double bound = 0.0;
};
CellUmbra cell_umbra(const Receiver& rc, const SenderMap& m, double u0, double u1, double v0,
                     double v1, const Vec3* poly, int np, const Vec3& nx,
                     const BlockerSet& blockers, const int* cand, int count, double eps,
                     double scale, double give_up);

/// The mean of J(u, v) F(x(u, v) → what the candidates leave of the receiver) at one point
/// drawn in each quarter of the cell [u0, u1] × [v0, v1] of the map m (stratified: unbiased),
/// the points from the stream `key` of uniform(); times the cell's du dv, an estimate of
/// ∫_cell F(x → visible part of r) dA_x. `points` counts the evaluations (umbrae.cpp).
double seen_at_drawn_points(const Receiver& rc, const SenderMap& m, double u0, double u1, double v0,
                            double v1, const Vec3& ns, const BlockerSet& blockers, const int* cand,
                            int n, double eps, std::uint64_t key, std::size_t& points);

}  // namespace formfactor::detail
