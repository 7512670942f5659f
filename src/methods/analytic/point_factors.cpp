// Form factors from differential elements to every patch, with obstructions: per entry, the
// blockers that can matter are culled by plane tests and the rest handed to
// point_to_polygon_obstructed (the exact shadow clipping of the obstructed analytic method).

#include "formfactor/methods/point_factors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/obstructed.h"

namespace formfactor {

namespace {

// A polygon that blocks, with a bounding sphere for the quick tests.
struct Blocker {
    Polygon polygon;
    Vec3 center = Vec3::Zero();
    double radius = 0.0;
    int source = 0;  // surface index, or −1 − patch index for a patch without a surface
};

// A receiving patch: its plane and the convex hull of its vertices (counter-clockwise about
// the normal), the base of the pyramid from a point over it.
struct Receiver {
    Plane plane;
    std::vector<Vec3> hull;
    Vec3 hull_center = Vec3::Zero();
    int source = 0;
};

Blocker make_blocker(const Polygon& p, int source) {
    Blocker b;
    b.polygon = p;
    b.source = source;
    const Bounds3 box = bounds(p);
    b.center = 0.5 * (box.lo + box.hi);
    for (const Vec3& v : p.vertices) b.radius = std::max(b.radius, (v - b.center).norm());
    return b;
}

// Convex hull (Andrew's monotone chain) of the polygon's vertices in its plane, counter-clockwise
// about its normal; collinear points dropped.
std::vector<Vec3> convex_hull(const Polygon& p) {
    const PlaneFrame f = frame_of(p);
    std::vector<std::pair<Vec2, std::size_t>> pts;
    pts.reserve(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) pts.emplace_back(f.to_local(p[k]), k);
    std::sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) {
        return a.first.x() < b.first.x() ||
               (a.first.x() == b.first.x() && a.first.y() < b.first.y());
    });
    auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
        return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    std::vector<std::pair<Vec2, std::size_t>> h(2 * pts.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        while (k >= 2 && cross(h[k - 2].first, h[k - 1].first, pts[i].first) <= 0.0) --k;
        h[k++] = pts[i];
    }
    for (std::size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
        while (k >= t && cross(h[k - 2].first, h[k - 1].first, pts[i - 1].first) <= 0.0) --k;
        h[k++] = pts[i - 1];
    }
    std::vector<Vec3> out;
    for (std::size_t i = 0; i + 1 < k; ++i) out.push_back(p[h[i].second]);
    return out;
}

// The blockers of a scene: each surface with patches and no holes as one polygon (its patches
// tile it), the patches of surfaces with holes, patches without a surface, and every
// obstruction-only surface.
std::vector<Blocker> scene_blockers(const Scene& scene) {
    std::vector<Blocker> out;
    std::vector<char> whole(scene.surfaces.size(), 0);
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        const Surface& sf = scene.surfaces[s];
        if (sf.obstruction) {
            out.push_back(make_blocker(sf.polygon, static_cast<int>(s)));
            whole[s] = 1;
        }
    }
    std::vector<char> has_patch(scene.surfaces.size(), 0);
    for (const Patch& p : scene.patches)
        if (p.surface >= 0 && static_cast<std::size_t>(p.surface) < scene.surfaces.size())
            has_patch[static_cast<std::size_t>(p.surface)] = 1;
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        const Surface& sf = scene.surfaces[s];
        if (!sf.obstruction && has_patch[s] && sf.holes.empty()) {
            out.push_back(make_blocker(sf.polygon, static_cast<int>(s)));
            whole[s] = 1;
        }
    }
    for (std::size_t j = 0; j < scene.patches.size(); ++j) {
        const Patch& p = scene.patches[j];
        const bool valid =
            p.surface >= 0 && static_cast<std::size_t>(p.surface) < scene.surfaces.size();
        if (valid && whole[static_cast<std::size_t>(p.surface)]) continue;
        out.push_back(make_blocker(p.polygon, valid ? p.surface : -1 - static_cast<int>(j)));
    }
    return out;
}

int receiver_source(const Scene& scene, std::size_t j) {
    const int s = scene.patches[j].surface;
    return s >= 0 && static_cast<std::size_t>(s) < scene.surfaces.size() ? s
                                                                         : -1 - static_cast<int>(j);
}

// True when every vertex of b is on the outer side (≤ limit) of the plane n·y = n·o.
bool all_outside(const Blocker& b, const Vec3& n, const Vec3& o, double limit) {
    if (n.dot(b.center - o) + b.radius * n.norm() <= limit) return true;
    for (const Vec3& v : b.polygon.vertices)
        if (n.dot(v - o) > limit) return false;
    return true;
}

}  // namespace

DenseMatrix point_form_factors(const Scene& scene, const std::vector<Vec3>& positions,
                               const std::vector<Vec3>& normals, int threads,
                               ProgressSink* progress_sink) {
    if (positions.size() != normals.size())
        throw Error(fmt::format("point_form_factors: {} positions and {} normals", positions.size(),
                                normals.size()));
    std::vector<Vec3> unit(normals.size());
    for (std::size_t m = 0; m < positions.size(); ++m) {
        if (!positions[m].allFinite())
            throw Error(fmt::format("point {}: position is not finite", m));
        const double big = normals[m].cwiseAbs().maxCoeff();
        if (!normals[m].allFinite() || !(big > 0.0))
            throw Error(fmt::format("point {}: the normal must be a finite non-zero vector", m));
        unit[m] = (normals[m] / big).normalized();  // scaled first: no underflow, no overflow
    }
    const std::size_t M = positions.size(), N = scene.patches.size();
    DenseMatrix F = DenseMatrix::Zero(static_cast<Eigen::Index>(M), static_cast<Eigen::Index>(N));
    if (M == 0 || N == 0) return F;

    const std::vector<Blocker> blockers = scene_blockers(scene);
    Bounds3 box = scene.bounds();
    for (const Patch& p : scene.patches)
        for (const Vec3& v : p.polygon.vertices) box.extend(v);
    const double eps = 1e-11 * (box.empty() ? 1.0 : box.diagonal().norm());
    std::vector<Receiver> receivers(N);
    for (std::size_t j = 0; j < N; ++j) {
        Receiver& r = receivers[j];
        r.plane = plane_of(scene.patches[j].polygon);
        r.hull = convex_hull(scene.patches[j].polygon);
        for (const Vec3& v : r.hull) r.hull_center += v;
        if (!r.hull.empty()) r.hull_center /= static_cast<double>(r.hull.size());
        r.source = receiver_source(scene, j);
    }

    Progress progress("point factors", M * N, progress_sink);
    parallel_for(M * N, threads, [&](std::size_t e) {
        const std::size_t m = e / N, j = e % N;
        const Vec3& x = positions[m];
        const Vec3& n = unit[m];
        const Polygon& target = scene.patches[j].polygon;
        const Receiver& r = receivers[j];
        double f = 0.0;
        if (r.plane.signed_distance(x) > 0.0 && r.hull.size() >= 3) {
            // Inward side planes of the pyramid from x over the receiver's hull.
            std::vector<Vec3> sides;
            sides.reserve(r.hull.size());
            for (std::size_t k = 0; k < r.hull.size(); ++k) {
                Vec3 s = (r.hull[k] - x).cross(r.hull[(k + 1) % r.hull.size()] - x);
                const double len = s.norm();
                if (!(len > 0.0)) continue;
                s /= len;
                if (s.dot(r.hull_center - x) < 0.0) s = -s;
                sides.push_back(s);
            }
            std::vector<Polygon> cand;
            for (const Blocker& b : blockers) {
                if (b.source == r.source) continue;  // a plane cannot hide a part of itself
                if (all_outside(b, n, x, 0.0)) continue;
                if (all_outside(b, r.plane.n, r.plane.n * r.plane.d, eps)) continue;
                bool out = false;
                for (const Vec3& s : sides)
                    if ((out = all_outside(b, s, x, 0.0))) break;
                if (!out) cand.push_back(b.polygon);
            }
            f = cand.empty() ? point_to_polygon(x, n, target)
                             : point_to_polygon_obstructed(x, n, target, cand);
        }
        F(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(j)) = f;
        progress.advance();
    });
    progress.finish();
    return F;
}

}  // namespace formfactor
