#pragma once
// Hand-built scenes for the visibility and Monte-Carlo tests (independent of the scene module).

#include <string>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/scene/scene.h"

namespace formfactor::mc_test {

inline Polygon quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return Polygon{{a, b, c, d}}; }

/// A scene whose patches are `patches` (one surface each) plus obstruction-only `blockers`.
inline Scene scene_of(const std::vector<Polygon>& patches,
                      const std::vector<Polygon>& blockers = {}) {
    Scene s;
    s.name = "test";
    s.materials.push_back(Material{});
    for (const Polygon& p : patches) {
        Surface sf;
        sf.name = "s";
        sf.name += std::to_string(s.surfaces.size());
        sf.polygon = p;
        s.patches.push_back(formfactor::make_patch(p, static_cast<int>(s.surfaces.size())));
        s.surfaces.push_back(sf);
    }
    for (const Polygon& p : blockers) {
        Surface sf;
        sf.name = "o";
        sf.name += std::to_string(s.surfaces.size());
        sf.polygon = p;
        sf.obstruction = true;
        s.surfaces.push_back(sf);
    }
    return s;
}

inline Scene translated(Scene s, const Vec3& t) {
    for (auto& sf : s.surfaces)
        for (auto& v : sf.polygon.vertices) v += t;
    for (auto& p : s.patches) {
        for (auto& v : p.polygon.vertices) v += t;
        p.centroid += t;
    }
    return s;
}

/// Catalog C-11: a×b rectangles at z = 0 (facing +z) and z = c (facing −z).
inline Scene parallel_rects(double a, double b, double c) {
    return scene_of({quad(Vec3(0, 0, 0), Vec3(a, 0, 0), Vec3(a, b, 0), Vec3(0, b, 0)),
                     quad(Vec3(0, b, c), Vec3(a, b, c), Vec3(a, 0, c), Vec3(0, 0, c))});
}

/// Catalog C-14 (l = w = h = 1): unit squares at z = 0 (facing +z) and y = 0 (facing +y).
inline Scene perpendicular_squares() {
    return scene_of({quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)),
                     quad(Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 0, 0), Vec3(0, 0, 0))});
}

/// The inside of the unit cube, each face split into n×n patches, normals inwards.
inline Scene unit_cube(int n) {
    std::vector<Polygon> polys;
    // Each face: origin o and edge vectors u, v.
    const Vec3 faces[6][3] = {
        {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)},  // z = 0
        {Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0)},  // z = 1
        {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 1)},  // y = 0
        {Vec3(0, 1, 0), Vec3(1, 0, 0), Vec3(0, 0, 1)},  // y = 1
        {Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)},  // x = 0
        {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)},  // x = 1
    };
    for (const auto& f : faces)
        for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) {
                const Vec3 o = f[0] + (double(c) / n) * f[1] + (double(r) / n) * f[2];
                const Vec3 du = f[1] / n, dv = f[2] / n;
                Polygon q = quad(o, o + du, o + du + dv, o + dv);
                if (normal(q).dot(Vec3(0.5, 0.5, 0.5) - centroid(q)) < 0)
                    q = quad(o, o + dv, o + du + dv, o + du);  // face inwards
                polys.push_back(q);
            }
    Scene s = scene_of(polys);
    s.enclosure = true;
    return s;
}

}  // namespace formfactor::mc_test
