#pragma once
// Closed models for the closed-model tests (scenes through scene_of()): rooms made of unit cells (a
// box, an L, a U, a room with a box standing on its floor), a faceted sphere, and vertex jitter.

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/scene/scene.h"

namespace formfactor::testing {

/// Which unit cells (i, j, k) of an nx × ny × nz block are inside the room.
struct Cells {
    int nx = 1, ny = 1, nz = 1;
    std::function<bool(int, int, int)> inside = [](int, int, int) { return true; };
    bool at(int i, int j, int k) const {
        return i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz && inside(i, j, k);
    }
};

/// The boundary of the cells' union as squares of side `size`, each facing into the room
/// (one surface per cell face: subdivision keeps every face on one grid, no T-junctions).
inline std::vector<Polygon> room_faces(const Cells& c, double size) {
    std::vector<Polygon> out;
    for (int i = 0; i < c.nx; ++i)
        for (int j = 0; j < c.ny; ++j)
            for (int k = 0; k < c.nz; ++k) {
                if (!c.at(i, j, k)) continue;
                for (int axis = 0; axis < 3; ++axis)
                    for (int side = 0; side < 2; ++side) {
                        int n[3] = {i, j, k};
                        n[axis] += side ? 1 : -1;
                        if (c.at(n[0], n[1], n[2])) continue;
                        // The face's plane, its two in-plane axes, and the inward normal.
                        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
                        Vec3 o(i, j, k);
                        o[axis] += side;
                        Vec3 du = Vec3::Zero(), dv = Vec3::Zero();
                        du[u] = 1;
                        dv[v] = 1;
                        Polygon q{{o, o + du, o + du + dv, o + dv}};
                        // du × dv points along +axis; inward is −axis on the far side.
                        if (side == 1) q = Polygon{{o, o + dv, o + du + dv, o + du}};
                        for (Vec3& p : q.vertices) p *= size;
                        out.push_back(q);
                    }
            }
    return out;
}

/// A faceted sphere (rings × segments, quads and the poles' triangles), fronts outwards,
/// built on one shared vertex list (watertight).
inline std::vector<Polygon> sphere_faces(const Vec3& centre, double radius, int rings,
                                         int segments) {
    auto at = [&](int r, int s) {
        const double th = M_PI * r / rings, ph = 2 * M_PI * (s % segments) / segments;
        return Vec3(centre + radius * Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph),
                                           std::cos(th)));
    };
    const Vec3 top = centre + Vec3(0, 0, radius), bottom = centre - Vec3(0, 0, radius);
    std::vector<Polygon> out;
    for (int s = 0; s < segments; ++s) {
        out.push_back(Polygon{{top, at(1, s), at(1, s + 1)}});
        for (int r = 1; r + 1 < rings; ++r)
            out.push_back(Polygon{{at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1)}});
        out.push_back(Polygon{{bottom, at(rings - 1, s + 1), at(rings - 1, s)}});
    }
    return out;
}

/// Every vertex moved by up to `amount` in each coordinate. shared: one displacement per
/// position (the model stays watertight exactly); otherwise each polygon's copy moves on its
/// own (cracks of ~amount between neighbours).
inline std::vector<Polygon> jittered(std::vector<Polygon> polys, double amount, bool shared,
                                     unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-amount, amount);
    auto shift = [&](const Vec3& p) {
        if (!shared) return Vec3(u(rng), u(rng), u(rng));
        // A displacement that depends only on the position (hash of its coordinates).
        std::seed_seq seq{std::llround(p.x() * 1e6), std::llround(p.y() * 1e6),
                          std::llround(p.z() * 1e6), static_cast<long long>(seed)};
        std::mt19937_64 local(seq);
        return Vec3(u(local), u(local), u(local));
    };
    for (Polygon& q : polys)
        for (Vec3& p : q.vertices) p += shift(p);
    return polys;
}

/// The rooms of the tests, size 1 per cell.
inline Cells box_room() { return Cells{2, 2, 2}; }
inline Cells l_room() {
    return Cells{3, 2, 1, [](int i, int j, int) { return !(i > 0 && j == 1); }};
}
inline Cells u_room() {
    return Cells{3, 2, 1, [](int i, int j, int) { return !(i == 1 && j == 1); }};
}
/// A 3 × 3 × 2 room whose middle floor cell is a box standing on the floor.
inline Cells box_on_floor_room() {
    return Cells{3, 3, 2, [](int i, int j, int k) { return !(i == 1 && j == 1 && k == 0); }};
}

}  // namespace formfactor::testing
