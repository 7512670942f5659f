#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"
#include "scene/text.h"

namespace formfactor {

namespace {

// How a polygon is split: the pieces (the polygon itself when it is a quad or a triangle, else
// its triangles) and per piece the grid (n_u, n_v) for quads or n for triangles.
struct Plan {
    std::vector<Polygon> pieces;
    std::vector<std::array<double, 2>> grid;  // quads: {n_u, n_v}; triangles: {n, n}
};

Plan plan_for_polygon(const Polygon& p, const SubdivisionOptions& o) {
    Plan plan;
    // Unsplit: n = 1, or every edge already within max_edge (any polygon stays whole).
    if ((o.max_edge == 0.0 && o.n == 1) || (o.max_edge > 0.0 && max_edge_length(p) <= o.max_edge)) {
        plan.pieces.push_back(p);
        plan.grid.push_back({1.0, 1.0});
        return plan;
    }
    // A quad is split bilinearly only when it is convex (collinear corners are fine): the
    // bilinear map of a planar convex quad tiles it exactly with planar children.
    if (p.size() == 4 && is_convex(p)) {
        plan.pieces.push_back(p);
    } else if (p.size() == 3) {
        plan.pieces.push_back(p);
    } else {
        const double d = diameter(p);
        for (const auto& t : triangulate(p)) {
            Polygon tri;
            for (int k : t) tri.vertices.push_back(p[static_cast<std::size_t>(k)]);
            // A zero-area sliver (a vertex on another triangle's edge) is no patch.
            if (area(tri) > 1e-14 * d * d) plan.pieces.push_back(std::move(tri));
        }
    }
    for (const Polygon& q : plan.pieces) {
        if (o.max_edge > 0.0) {
            const double L = o.max_edge;
            if (q.size() == 4) {
                const double nu =
                    std::ceil(std::max((q[1] - q[0]).norm(), (q[2] - q[3]).norm()) / L);
                const double nv =
                    std::ceil(std::max((q[3] - q[0]).norm(), (q[2] - q[1]).norm()) / L);
                plan.grid.push_back({std::max(1.0, nu), std::max(1.0, nv)});
            } else {
                const double n = std::max(1.0, std::ceil(max_edge_length(q) / L));
                plan.grid.push_back({n, n});
            }
        } else {
            plan.grid.push_back({double(o.n), double(o.n)});
        }
    }
    return plan;
}

// A surface with holes: its convex pieces (polygon minus holes), each planned on its own.
Plan plan_for(const Surface& s, const SubdivisionOptions& o) {
    if (s.holes.empty()) return plan_for_polygon(s.polygon, o);
    Plan plan;
    for (const Polygon& piece : subtract_holes(s.polygon, s.holes)) {
        Plan sub = plan_for_polygon(piece, o);
        plan.pieces.insert(plan.pieces.end(), sub.pieces.begin(), sub.pieces.end());
        plan.grid.insert(plan.grid.end(), sub.grid.begin(), sub.grid.end());
    }
    return plan;
}

void split_quad(const Polygon& q, int nu, int nv, int surface, std::vector<Patch>& out) {
    auto P = [&](int c, int r) {
        const double s = double(c) / nu, t = double(r) / nv;
        // Exact corners and edges: avoid rounding the surface's own vertices.
        if (c == 0 && r == 0) return q[0];
        if (c == nu && r == 0) return q[1];
        if (c == nu && r == nv) return q[2];
        if (c == 0 && r == nv) return q[3];
        return Vec3((1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] +
                    (1 - s) * t * q[3]);
    };
    for (int r = 0; r < nv; ++r)
        for (int c = 0; c < nu; ++c)
            out.push_back(
                make_patch(Polygon{{P(c, r), P(c + 1, r), P(c + 1, r + 1), P(c, r + 1)}}, surface));
}

void split_triangle(const Polygon& t, int n, int surface, std::vector<Patch>& out) {
    auto P = [&](int i, int j) {
        if (i == 0 && j == 0) return t[0];
        if (i == n && j == 0) return t[1];
        if (i == 0 && j == n) return t[2];
        return Vec3(t[0] + (double(i) / n) * (t[1] - t[0]) + (double(j) / n) * (t[2] - t[0]));
    };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n - j; ++i) {
            out.push_back(make_patch(Polygon{{P(i, j), P(i + 1, j), P(i, j + 1)}}, surface));
            if (i < n - 1 - j)
                out.push_back(
                    make_patch(Polygon{{P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)}}, surface));
        }
}

}  // namespace

void validate(const SubdivisionOptions& options) {
    if (options.n < 1)
        throw OptionError("subdivide",
                          "must be at least 1 (got " + std::to_string(options.n) + ")");
    if (std::isnan(options.max_edge) || options.max_edge < 0.0 || std::isinf(options.max_edge))
        throw OptionError(
            "max_edge", "must be a positive length (got " + detail::exact(options.max_edge) + ")");
    if (options.max_edge > 0.0 && options.n > 1)
        throw OptionError("max_edge", "cannot be combined with a subdivision n > 1");
}

double subdivision_patch_count(const Scene& scene, const SubdivisionOptions& options) {
    validate(options);
    double total = 0.0;
    for (const Surface& s : scene.surfaces) {
        if (s.obstruction) continue;
        for (const auto& g : plan_for(s, options).grid) total += g[0] * g[1];
    }
    return total;
}

void subdivide(Scene& scene, const SubdivisionOptions& options) {
    validate(options);
    const char* option = options.max_edge > 0.0 ? "max_edge" : "subdivide";

    // Count first, in floating point, so that absurd values are refused before anything is built.
    std::vector<Plan> plans(scene.surfaces.size());
    double total = 0.0;
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        if (scene.surfaces[s].obstruction) continue;
        plans[s] = plan_for(scene.surfaces[s], options);
        for (const auto& g : plans[s].grid) total += g[0] * g[1];
    }
    if (!(total <= kMaxPatches))
        throw OptionError(option, "would make " + detail::short_number(total) +
                                      " patches (at most " + detail::short_number(kMaxPatches) +
                                      " allowed)");

    std::vector<Patch> patches;
    patches.reserve(static_cast<std::size_t>(total));
    for (std::size_t s = 0; s < scene.surfaces.size(); ++s) {
        if (scene.surfaces[s].obstruction) continue;
        const Plan& plan = plans[s];
        for (std::size_t k = 0; k < plan.pieces.size(); ++k) {
            const Polygon& q = plan.pieces[k];
            const int a = static_cast<int>(plan.grid[k][0]);
            const int b = static_cast<int>(plan.grid[k][1]);
            const int surface = static_cast<int>(s);
            if (a == 1 && b == 1)
                patches.push_back(make_patch(q, surface));
            else if (q.size() == 4)
                split_quad(q, a, b, surface, patches);
            else
                split_triangle(q, a, surface, patches);
        }
    }
    scene.patches = std::move(patches);
}

}  // namespace formfactor
