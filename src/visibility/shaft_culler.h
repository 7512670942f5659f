#pragma once
// Conservative shaft culling between pairs of patches (private to the library; DESIGN.md puts
// shaft culling in the visibility module). Used by mc-target to settle, without rays, the pairs
// that nothing can block. Deliberately independent of the analytic method's obstruction
// classification (src/methods/analytic/shaft.cpp): mc-target is the Monte-Carlo check of that
// method and must not share its reasoning. Only the bounding-volume tree is shared
// (geometry/box_tree.h): it decides which blockers are tested, never how.

#include <array>
#include <cstddef>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/scene/scene.h"
#include "geometry/box_tree.h"

namespace formfactor {

/// The blocking polygons of a scene, as Visibility sees them (every patch, then every
/// obstruction-only surface), in a bounding-volume hierarchy.
class ShaftCuller {
  public:
    explicit ShaftCuller(const Scene& scene);

    /// True when no blocking polygon other than patches i and j can meet a segment from a point
    /// of patch i to a point of patch j with each end in front of the other patch's plane (the
    /// segments that carry mc-target's rays). The shaft is the convex hull of the two patches
    /// cut by both planes; a blocker is cleared when a plane separates it from the shaft: the
    /// back of either patch's plane, a face of the hull (an edge of one patch and a vertex of
    /// the other with every vertex on one side), or the blocker's own plane. Blockers that only
    /// touch the shaft (within 1e-9 of the scene's size: coplanar or edge-sharing neighbours)
    /// are cleared. False means "may be blocked", never "blocked".
    bool unoccluded(int i, int j) const;

    /// The same test for the segments between any two planar polygons (a surface and another,
    /// say: when it holds, it holds for every pair of their patches), with every blocking
    /// polygon a candidate.
    bool unoccluded(const Polygon& a, const Polygon& b) const;

    /// Number of blocking polygons.
    std::size_t size() const { return polys_.size(); }

  private:
    struct Poly {
        int first = 0, count = 0;  // vertices [first, first + count) of verts_
        Bounds3 box;
        Vec3 normal = Vec3::Zero();  // unit (Newell), zero when degenerate
        double offset = 0;           // normal · (a vertex)
    };
    struct Plane {
        Vec3 m = Vec3::Zero();  // unit, pointing out of the shaft
        double d = 0;           // the shaft is {p : m·p ≤ d}
    };
    static constexpr int kMaxPlanes = 64;
    static constexpr int kMaxVertices = 16;  // larger patches are not culled (answer false)

    bool clear(const Vec3* vi, int ni, const Vec3* vj, int nj, int skip_i, int skip_j) const;

    std::vector<Vec3> verts_;
    std::vector<Poly> polys_;
    detail::BoxTree tree_;  // over the polygons' boxes
    std::size_t patch_count_ = 0;
    double eps_ = 0;
};

}  // namespace formfactor
