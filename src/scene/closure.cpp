// Closed-model recognition (formfactor/scene/closure.h).

#include "formfactor/scene/closure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

#include "formfactor/geometry/polygon.h"
#include "scene/text.h"

namespace formfactor {
namespace {

Bounds3 patch_bounds(const Scene& scene) {
    Bounds3 b;
    for (const Patch& p : scene.patches)
        for (const Vec3& v : p.polygon.vertices) b.extend(v);
    return b;
}

struct CellHash {
    std::size_t operator()(const std::array<std::int64_t, 3>& c) const {
        std::uint64_t h = 0x9E3779B97F4A7C15ull;
        for (std::int64_t x : c) h = (h ^ static_cast<std::uint64_t>(x)) * 0xBF58476D1CE4E5B9ull;
        return static_cast<std::size_t>(h ^ (h >> 31));
    }
};

struct UnionFind {
    std::vector<int> parent;
    explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
    int find(int a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    }
    void join(int a, int b) { parent[find(a)] = find(b); }
};

// Does the ray from p along d cross the polygon (t > 0, inside its triangles)? Möller–Trumbore;
// used only for the parity test of a body against an enclosure.
bool crosses(const Vec3& p, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
    const Vec3 e1 = b - a, e2 = c - a, s = d.cross(e2);
    const double det = e1.dot(s);
    if (det == 0.0) return false;
    const Vec3 o = p - a;
    const double u = o.dot(s) / det;
    if (u < 0.0 || u > 1.0) return false;
    const Vec3 q = o.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0.0 || u + v > 1.0) return false;
    return e2.dot(q) / det > 0.0;
}

}  // namespace

double vertex_tolerance(const Scene& scene) {
    const Bounds3 b = patch_bounds(scene);
    return b.empty() ? 0.0 : kVertexTolerance * b.diagonal().norm();
}

WeldedPatches weld_patches(const Scene& scene) {
    WeldedPatches w;
    w.tolerance = vertex_tolerance(scene);
    const Bounds3 box = patch_bounds(scene);
    // Grid cells of twice the tolerance: a vertex's partners lie in its cell or a neighbour.
    const double cell = w.tolerance > 0 ? 2.0 * w.tolerance : 1.0;
    std::unordered_map<std::array<std::int64_t, 3>, std::vector<int>, CellHash> grid;
    auto cell_of = [&](const Vec3& v) {
        std::array<std::int64_t, 3> c;
        for (int k = 0; k < 3; ++k)
            c[k] = static_cast<std::int64_t>(std::floor((v[k] - box.lo[k]) / cell));
        return c;
    };
    const double tol2 = w.tolerance * w.tolerance;
    w.vertex.resize(scene.patches.size());
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        for (const Vec3& v : scene.patches[i].polygon.vertices) {
            const auto c = cell_of(v);
            int found = -1;
            for (int dx = -1; dx <= 1 && found < 0; ++dx)
                for (int dy = -1; dy <= 1 && found < 0; ++dy)
                    for (int dz = -1; dz <= 1 && found < 0; ++dz) {
                        const auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
                        if (it == grid.end()) continue;
                        for (int k : it->second)
                            if ((w.positions[static_cast<std::size_t>(k)] - v).squaredNorm() <=
                                tol2) {
                                found = k;
                                break;
                            }
                    }
            if (found < 0) {
                found = static_cast<int>(w.positions.size());
                w.positions.push_back(v);
                grid[c].push_back(found);
            }
            w.vertex[i].push_back(found);
        }
    }
    return w;
}

Closure check_closure(const Scene& scene) { return check_closure(scene, weld_patches(scene)); }

bool known_enclosure(const Scene& scene) {
    return scene.enclosure || (!scene.patches.empty() && check_closure(scene).closed);
}

Closure check_closure(const Scene& scene, const WeldedPatches& welded) {
    Closure r;
    r.tolerance = welded.tolerance;
    const std::size_t n = scene.patches.size();
    if (n == 0) return r;
    // Each undirected edge (lo, hi): how often it is run lo → hi and hi → lo, and a patch of it.
    struct Use {
        int forward = 0, backward = 0, patch = -1;
    };
    std::unordered_map<std::uint64_t, Use> edges;
    UnionFind shells(n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::vector<int>& v = welded.vertex[i];
        for (std::size_t k = 0; k < v.size(); ++k) {
            const int a = v[k], b = v[(k + 1) % v.size()];
            if (a == b) continue;  // an edge shorter than the tolerance
            const auto lo = static_cast<std::uint64_t>(std::min(a, b));
            const auto hi = static_cast<std::uint64_t>(std::max(a, b));
            Use& u = edges[(lo << 32) | hi];
            (a < b ? u.forward : u.backward)++;
            if (u.patch >= 0) shells.join(u.patch, static_cast<int>(i));
            u.patch = static_cast<int>(i);
        }
    }
    r.edges = edges.size();
    for (const auto& [key, u] : edges) {
        const int uses = u.forward + u.backward;
        if (uses == 1)
            ++r.open_edges;
        else if (uses > 2)
            ++r.nonmanifold_edges;
        else if (u.forward != 1)
            ++r.misoriented_edges;
    }
    r.watertight = r.open_edges == 0 && r.nonmanifold_edges == 0 && r.misoriented_edges == 0;

    // Shells and their signed volumes (divergence theorem: positive when the fronts face out).
    std::vector<int> shell_of(n);
    std::unordered_map<int, int> index;
    for (std::size_t i = 0; i < n; ++i) {
        const int root = shells.find(static_cast<int>(i));
        const auto it = index.emplace(root, static_cast<int>(index.size())).first;
        shell_of[i] = it->second;
    }
    r.shells = index.size();
    if (!r.watertight) return r;
    const Bounds3 box = patch_bounds(scene);
    const Vec3 ref = 0.5 * (box.lo + box.hi);
    std::vector<double> volume(r.shells, 0.0), area_sum(r.shells, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
        const auto& p = scene.patches[i].polygon.vertices;
        const auto s = static_cast<std::size_t>(shell_of[i]);
        for (std::size_t k = 1; k + 1 < p.size(); ++k)
            volume[s] += (p[0] - ref).dot((p[k] - ref).cross(p[k + 1] - ref)) / 6.0;
        area_sum[s] += scene.patches[i].area;
    }
    // An enclosure has a clearly negative volume; anything else (a body, a flat twin plate) must
    // lie inside an enclosure: parity of crossings of a ray from one of its vertices.
    std::vector<char> enclosure(r.shells, 0);
    for (std::size_t s = 0; s < r.shells; ++s)
        enclosure[s] = volume[s] < -1e-9 * std::pow(area_sum[s], 1.5) ? 1 : 0;
    std::vector<std::vector<std::array<Vec3, 3>>> triangles(r.shells);
    for (std::size_t i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(shell_of[i]);
        if (!enclosure[s]) continue;
        const Polygon& poly = scene.patches[i].polygon;
        for (const auto& t : triangulate(poly))
            triangles[s].push_back({poly[static_cast<std::size_t>(t[0])],
                                    poly[static_cast<std::size_t>(t[1])],
                                    poly[static_cast<std::size_t>(t[2])]});
    }
    const Vec3 dir = Vec3(0.5773502691896258, 0.4714045207910317, 0.6666666666666666).normalized();
    std::vector<char> seen(r.shells, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(shell_of[i]);
        if (enclosure[s] || seen[s]) continue;
        seen[s] = 1;
        const Vec3 p = scene.patches[i].centroid;
        bool inside = false;
        for (std::size_t e = 0; e < r.shells && !inside; ++e) {
            if (!enclosure[e]) continue;
            std::size_t hits = 0;
            for (const auto& t : triangles[e]) hits += crosses(p, dir, t[0], t[1], t[2]) ? 1 : 0;
            inside = hits % 2 == 1;
        }
        if (!inside) ++r.exposed_bodies;
    }
    r.closed = r.exposed_bodies == 0;
    return r;
}

std::string Closure::summary() const {
    if (closed)
        return "yes (watertight within " + detail::short_number(tolerance) + ", " +
               std::to_string(shells) + (shells == 1 ? " shell" : " shells") +
               ": no ray from a front can escape)";
    if (edges == 0) return "no (no patches)";
    std::string why;
    auto add = [&](std::size_t count, const char* what) {
        if (count == 0) return;
        why += (why.empty() ? "" : ", ") + std::to_string(count) + " " + what;
    };
    add(open_edges, open_edges == 1 ? "open edge" : "open edges");
    add(nonmanifold_edges, nonmanifold_edges == 1 ? "edge of 3+ patches" : "edges of 3+ patches");
    add(misoriented_edges, misoriented_edges == 1 ? "edge run the same way by two patches"
                                                  : "edges run the same way by two patches");
    if (watertight)
        why = "watertight, but " + std::to_string(exposed_bodies) +
              (exposed_bodies == 1 ? " shell faces" : " shells face") + " outwards into open space";
    return "no (" + why + "; vertex tolerance " + detail::short_number(tolerance) + ")";
}

}  // namespace formfactor
