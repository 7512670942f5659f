#pragma once
// Scenes built by hand from polygons, independent of the scene module's loaders: the one
// scene-from-polygons builder of the tests, the unit cube, and the catalog's simple pairs.

#include <string>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/scene/scene.h"

namespace formfactor::testing {

/// The quad a, b, c, d (counter-clockwise seen from its front).
inline Polygon quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return Polygon{{a, b, c, d}}; }

/// The parallelogram with corner o and edges e1, e2 (front = e1 × e2).
inline Polygon quad(const Vec3& o, const Vec3& e1, const Vec3& e2) {
    return Polygon{{o, o + e1, o + e1 + e2, o + e2}};
}

/// Quad q (CCW) split n × n by bilinear interpolation, row-major.
inline std::vector<Polygon> split_quad(const Polygon& q, int n) {
    auto at = [&](double s, double t) {
        return (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3];
    };
    std::vector<Polygon> out;
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const double s0 = double(i) / n, s1 = double(i + 1) / n;
            const double t0 = double(j) / n, t1 = double(j + 1) / n;
            out.push_back(Polygon{{at(s0, t0), at(s1, t0), at(s1, t1), at(s0, t1)}});
        }
    }
    return out;
}

/// A scene named "test" with one surface per polygon of `surfaces` (named s0, s1, …) and the
/// obstruction-only `obstructions` (named o<k>, k counting on from the surfaces), one default
/// material; the surfaces are split into patches by subdivide() with n (n = 1: one patch per
/// surface).
inline Scene scene_of(const std::vector<Polygon>& surfaces,
                      const std::vector<Polygon>& obstructions = {}, int n = 1) {
    Scene s;
    s.name = "test";
    s.materials.push_back(Material{});
    auto add = [&](const Polygon& p, bool obstruction) {
        Surface sf;
        sf.name.assign(1, obstruction ? 'o' : 's');
        sf.name += std::to_string(s.surfaces.size());
        sf.polygon = p;
        sf.obstruction = obstruction;
        s.surfaces.push_back(sf);
    };
    for (const Polygon& p : surfaces) add(p, false);
    for (const Polygon& p : obstructions) add(p, true);
    subdivide(s, SubdivisionOptions{n, 0.0});
    return s;
}

/// The faces of the unit cube [0, 1]³ seen from inside, in the order x = 0, x = 1, y = 0,
/// y = 1, z = 0 (floor), z = 1 (ceiling); each faces into the cube.
inline std::vector<Polygon> unit_cube_faces() {
    const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ(), O = Vec3::Zero();
    return {
        quad(O, Y, Z),  // x = 0, normal +x
        quad(X, Z, Y),  // x = 1, normal −x
        quad(O, Z, X),  // y = 0, normal +y
        quad(Y, X, Z),  // y = 1, normal −y
        quad(O, X, Y),  // z = 0, normal +z
        quad(Z, Y, X),  // z = 1, normal −z
    };
}

/// The unit cube as a closed enclosure (scene "test-cube"): the faces of unit_cube_faces(),
/// named x0, x1, y0, y1, z0, z1, each with its own material of the same name, split n × n.
inline Scene unit_cube(int n = 1) {
    Scene s = scene_of(unit_cube_faces(), {}, n);
    s.name = "test-cube";
    s.enclosure = true;
    s.materials.clear();
    const char* names[6] = {"x0", "x1", "y0", "y1", "z0", "z1"};
    for (int f = 0; f < 6; ++f) {
        Material m;
        m.name = names[f];
        s.materials.push_back(m);
        s.surfaces[std::size_t(f)].name = names[f];
        s.surfaces[std::size_t(f)].material = f;
    }
    return s;
}

/// The scene moved by t.
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

/// Two unit squares 1 apart facing each other (C-11, a = b = c = 1), as polygons.
inline std::vector<Polygon> plates() {
    return {
        Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}},  // +z
        Polygon{{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)}},  // -z
    };
}

/// Area-weighted sum of the block of F from the patches of surface a to those of surface b.
template <class Matrix>
double surface_factor(const Scene& s, const Matrix& F, int a, int b) {
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < s.patches.size(); ++i) {
        if (s.patches[i].surface != a) continue;
        den += s.patches[i].area;
        for (std::size_t j = 0; j < s.patches.size(); ++j) {
            if (s.patches[j].surface == b) {
                num += s.patches[i].area *
                       F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
            }
        }
    }
    return num / den;
}

}  // namespace formfactor::testing
