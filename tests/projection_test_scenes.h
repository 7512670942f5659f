#pragma once
// Scenes built by hand for the projection-method tests (hemicube, hemiplane), independent of
// the scene module's loaders.

#include <cmath>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/scene/scene.h"

namespace projection_test {

using formfactor::Patch;
using formfactor::Polygon;
using formfactor::Scene;
using formfactor::Surface;
using formfactor::Vec3;

// Quad q (CCW) split n × n by bilinear interpolation, row-major.
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

// A scene whose surfaces are `surfaces` (each split n × n into patches) plus obstruction-only
// `obstructions`.
inline Scene make_scene(const std::vector<Polygon>& surfaces, int n = 1,
                        const std::vector<Polygon>& obstructions = {}) {
    Scene s;
    s.name = "test";
    s.materials.push_back({});
    for (const Polygon& p : surfaces) {
        Surface surf;
        surf.polygon = p;
        s.surfaces.push_back(surf);
        const int index = static_cast<int>(s.surfaces.size()) - 1;
        if (p.size() == 4) {
            for (const Polygon& c : split_quad(p, n))
                s.patches.push_back(formfactor::make_patch(c, index));
        } else {
            s.patches.push_back(formfactor::make_patch(p, index));
        }
    }
    for (const Polygon& p : obstructions) {
        Surface surf;
        surf.polygon = p;
        surf.obstruction = true;
        s.surfaces.push_back(surf);
    }
    return s;
}

// The unit cube [0,1]³, faces inward: floor, ceiling, x=0, x=1, y=0, y=1.
inline std::vector<Polygon> cube_faces() {
    return {
        Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}},  // floor +z
        Polygon{{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)}},  // ceiling -z
        Polygon{{Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1)}},  // x=0, +x
        Polygon{{Vec3(1, 0, 0), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(1, 1, 0)}},  // x=1, -x
        Polygon{{Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 0, 0)}},  // y=0, +y
        Polygon{{Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1)}},  // y=1, -y
    };
}

// Two unit squares 1 apart facing each other (C-11, a = b = c = 1).
inline std::vector<Polygon> plates() {
    return {
        Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}},  // +z
        Polygon{{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)}},  // -z
    };
}

// Area-weighted sum of the block of F from the patches of surface a to those of surface b.
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

}  // namespace projection_test

namespace projection_test {

// Exact F from a differential element at x (unit normal n) to a convex polygon wholly in front
// of it and unoccluded: Lambert's contour formula, F = 1/(2π) |Σ γ_k n·(R_k × R_k+1)/|R_k ×
// R_k+1||.
inline double lambert(const Vec3& x, const Vec3& n, const Polygon& poly) {
    double sum = 0.0;
    for (std::size_t k = 0; k < poly.size(); ++k) {
        const Vec3 a = poly[k] - x;
        const Vec3 b = poly[(k + 1) % poly.size()] - x;
        const Vec3 c = a.cross(b);
        const double len = c.norm();
        if (len == 0.0) continue;
        const double gamma = std::atan2(len, a.dot(b));
        sum += gamma * n.dot(c) / len;
    }
    return std::abs(sum) / (2.0 * formfactor::kPi);
}

}  // namespace projection_test
