#pragma once
/// Obstructed form factors between planar polygons: the exact point → polygon factor to the
/// visible part of a receiver (the blockers' shadows clipped out of it), and its adaptive
/// integration over a sender (Walton 2002, NISTIR 6925). The `analytic` method uses the same
/// code for the partly hidden pairs of a scene. See docs/analytic.md, "Obstructed scenes".

#include <cstddef>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor {

/// F from a differential element at x (unit normal n) to the part of `receiver` that x sees past
/// the `blockers` (planar polygons that block from both sides). The shadows of the blockers seen
/// from x (central projections onto the receiver's plane of their parts between x and the
/// receiver) are removed from the receiver and Lambert's formula is applied to what is left.
/// Exact up to rounding; never more than point_to_polygon(x, n, receiver).
double point_to_polygon_obstructed(const Vec3& x, const Vec3& n, const Polygon& receiver,
                                   const std::vector<Polygon>& blockers);

/// F_ab past the blockers, and what the computation knows about its accuracy.
struct ObstructedFormFactor {
    double value = 0;           ///< obstructed F_ab, in [0, unobstructed]
    double unobstructed = 0;    ///< polygon_to_polygon(a, b)
    double error_estimate = 0;  ///< estimated absolute error of value
    int max_level = 0;          ///< deepest subdivision of a (0: a whole)
    std::size_t cells = 0;      ///< final cells of a
};

/// F_ab with obstructions: the exact unobstructed F_ab minus 1/A_a ∫_a F_{dA_x → hidden part of
/// b} dA_x, the integral by adaptive subdivision of a, cut first along the integrand's kink lines
/// (tensor Gauss rules of orders 2, 3 and 4 per cell, the larger difference the estimate; cells
/// whose shafts no blocker meets are skipped) until the estimated absolute error ≤ tolerance.
ObstructedFormFactor polygon_to_polygon_obstructed(const Polygon& a, const Polygon& b,
                                                   const std::vector<Polygon>& blockers,
                                                   double tolerance);

}  // namespace formfactor
