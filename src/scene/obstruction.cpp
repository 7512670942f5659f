#include "formfactor/scene/obstruction.h"

#include <algorithm>
#include <limits>
#include <vector>

#include "formfactor/geometry/polygon.h"

namespace formfactor {

bool may_obstruct(const Scene& scene, double relative_tolerance) {
    for (const Surface& s : scene.surfaces)
        if (s.obstruction) return true;
    std::vector<const Polygon*> polys;
    if (!scene.surfaces.empty()) {
        for (const Surface& s : scene.surfaces) polys.push_back(&s.polygon);
    } else {
        for (const Patch& p : scene.patches) polys.push_back(&p.polygon);
    }
    Bounds3 box;
    for (const Polygon* p : polys)
        for (const Vec3& v : p->vertices) box.extend(v);
    if (box.empty()) return false;
    const double eps = relative_tolerance * box.diagonal().norm();
    // Surface k cannot block any segment between two other surfaces when all their vertices are
    // in one closed half-space of k's plane.
    for (std::size_t k = 0; k < polys.size(); ++k) {
        const Plane pl = plane_of(*polys[k]);
        // The scene's bounding box on one side of the plane (a wall of a convex room): no vertex
        // can be on the other side, without looking at each (O(1) instead of O(vertices)).
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (int c = 0; c < 8; ++c) {
            const Vec3 v((c & 1) ? box.hi.x() : box.lo.x(), (c & 2) ? box.hi.y() : box.lo.y(),
                         (c & 4) ? box.hi.z() : box.lo.z());
            const double sd = pl.signed_distance(v);
            lo = std::min(lo, sd);
            hi = std::max(hi, sd);
        }
        if (lo >= -eps || hi <= eps) continue;
        bool front = false, behind = false;
        for (std::size_t m = 0; m < polys.size() && !(front && behind); ++m) {
            if (m == k) continue;
            for (const Vec3& v : polys[m]->vertices) {
                const double s = pl.signed_distance(v);
                front = front || s > eps;
                behind = behind || s < -eps;
            }
        }
        if (front && behind) return true;
    }
    return false;
}

}  // namespace formfactor
