#pragma once
// The point kernel of the obstructed analytic method (see point_kernel.cpp): F from a point to
// the part of a receiver that blocker pieces hide, by exact shadow polygons.

#include <vector>

#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

struct PointResult {
    double hidden = 0.0;
    double unobstructed = 0.0;  // F(x → r), when asked for
    bool all_hidden = false;    // x sees nothing of r (rounding slivers apart)
};

/// x's height h above the receiver's plane, the receiver's part rp in front of x's plane (normal
/// nx) and that part in the receiver's plane coordinates; false when x sees none of it.
bool receiver_in_front(const Receiver& rc, const Vec3& x, const Vec3& nx, double& h, Poly3& rp,
                       Poly2& whole);

/// The shadows that the candidate pieces cast from x (at height h above the receiver's plane) on
/// rp, the receiver's part in front of x (`whole` in the receiver's plane coordinates): convex
/// polygons in those coordinates, each a convex solid's whole shadow when x culls its back faces,
/// else one piece's. solid_of[k]: the solid of shadows[k], or −2 − the piece's index for a
/// piece's own.
void cast_shadows(const Receiver& rc, const Vec3& x, double h, const Poly3& rp, const Poly2& whole,
                  const BlockerSet& blockers, const int* cand, int count, double eps,
                  std::vector<Poly2>& shadows, std::vector<int>& solid_of);

/// F(x → part of the receiver hidden by the candidate pieces cand[0, count)), x on a sender of
/// normal nx; with F(x → r) when want_unobstructed.
PointResult evaluate_point(const Receiver& rc, const Vec3& x, const Vec3& nx,
                           const BlockerSet& blockers, const int* cand, int count, double eps,
                           bool want_unobstructed);

}  // namespace formfactor::detail
