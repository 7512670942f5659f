#pragma once
// Fixtures of the solve / repair / render tests: exact enclosure matrices (copied from the
// reference catalog, Howell C-11 and C-14) and a hand-built open box.

#include <cstdint>
#include <random>
#include <string>

#include "formfactor/geometry/polygon.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"
#include "scenes.h"

namespace formfactor::testing {

// Unit cube (unit_cube()), interior faces: opposite 0.19982489569838746 (C-11, a = b = c = 1),
// adjacent 0.20004377607540316 (C-14, l = w = h = 1). Face order: x=0, x=1, y=0, y=1, z=0, z=1.
inline constexpr double kCubeOpposite = 0.19982489569838746;
inline constexpr double kCubeAdjacent = 0.20004377607540316;

inline FormFactors cube_matrix() {
    FormFactors ff;
    ff.F = DenseMatrix::Constant(6, 6, kCubeAdjacent);
    for (int i = 0; i < 6; ++i) {
        ff.F(i, i) = 0.0;
        ff.F(i, i ^ 1) = kCubeOpposite;
    }
    ff.areas.assign(6, 1.0);
    return ff;
}

// 1×2×3 box, interior faces (catalog "box_1x2x3_interior_faces"), areas 6, 6, 3, 3, 2, 2.
inline FormFactors box123_matrix() {
    FormFactors ff;
    ff.F.resize(6, 6);
    ff.F << 0.0, 0.4755764365329533, 0.15949835073952498, 0.15949835073952498, 0.10271343099399842,
        0.10271343099399842,  //
        0.4755764365329533, 0.0, 0.15949835073952498, 0.15949835073952498, 0.10271343099399842,
        0.10271343099399842,  //
        0.3189967014790498, 0.3189967014790498, 0.0, 0.1464145779311968, 0.10779600955535155,
        0.10779600955535155,  //
        0.3189967014790498, 0.3189967014790498, 0.1464145779311968, 0.0, 0.10779600955535155,
        0.10779600955535155,  //
        0.30814029298199513, 0.30814029298199513, 0.16169401433302732, 0.16169401433302732, 0.0,
        0.06033138536995475,  //
        0.30814029298199513, 0.30814029298199513, 0.16169401433302732, 0.16169401433302732,
        0.06033138536995475, 0.0;
    ff.areas = {6, 6, 3, 3, 2, 2};
    return ff;
}

// A random matrix with zero diagonal, reciprocal for the given random areas, row sums in
// (0.5, 0.95): an open scene with N patches, to exercise the parallel paths.
inline FormFactors random_open_matrix(int n, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    FormFactors ff;
    ff.areas.resize(static_cast<std::size_t>(n));
    for (auto& a : ff.areas) a = 0.5 + u(rng);
    DenseMatrix G = DenseMatrix::Zero(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) G(i, j) = G(j, i) = u(rng);
    // Scale so the largest row of F sums to 0.95: F = A⁻¹ G / s.
    double s = 0.0;
    for (int i = 0; i < n; ++i) s = std::max(s, G.row(i).sum() / ff.areas[std::size_t(i)]);
    s /= 0.95;
    ff.F.resize(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) ff.F(i, j) = G(i, j) / (s * ff.areas[std::size_t(i)]);
    return ff;
}

// n×n sub-quads of the parallelogram (o, o + e1, o + e1 + e2, o + e2), row-major.
inline std::vector<Polygon> grid(const Vec3& o, const Vec3& e1, const Vec3& e2, int n) {
    std::vector<Polygon> out;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            out.push_back(quad(o + (double(i) / n) * e1 + (double(j) / n) * e2, e1 / n, e2 / n));
    return out;
}

// A Cornell-like box, open at z = 1 (front), unit size: surfaces left (x = 0, red), right
// (x = 1, green), floor, ceiling, back (white), each split into n×n patches. The camera looks in
// through the opening. Radiances: fixed per surface (no solve needed to test the renderer).
inline Scene open_box_scene(int n, std::vector<Rgb>& radiance) {
    Scene s;
    s.name = "test-open-box";
    const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ(), O = Vec3::Zero();
    struct Wall {
        const char* name;
        Vec3 o, e1, e2;
        Rgb value;
    };
    const Wall walls[5] = {
        {"left", O, Y, Z, Rgb(0.6, 0.05, 0.05)},   // normal +x
        {"right", X, Z, Y, Rgb(0.05, 0.5, 0.05)},  // normal −x
        {"floor", O, Z, X, Rgb(0.5, 0.5, 0.5)},    // normal +y
        {"ceiling", Y, X, Z, Rgb(0.4, 0.4, 0.4)},  // normal −y
        {"back", O, X, Y, Rgb(0.45, 0.45, 0.45)},  // normal +z
    };
    for (int w = 0; w < 5; ++w) {
        Material m;
        m.name = walls[w].name;
        s.materials.push_back(m);
        Surface sf;
        sf.name = walls[w].name;
        sf.polygon = quad(walls[w].o, walls[w].e1, walls[w].e2);
        sf.material = w;
        s.surfaces.push_back(sf);
        for (Polygon& p : grid(walls[w].o, walls[w].e1, walls[w].e2, n)) {
            s.patches.push_back(formfactor::make_patch(std::move(p), w));
            radiance.push_back(walls[w].value);
        }
    }
    Camera c;
    c.eye = Vec3(0.5, 0.5, 2.5);
    c.target = Vec3(0.5, 0.5, 0.0);
    c.up = Y;
    c.fov_degrees = 40.0;
    s.camera = c;
    return s;
}

}  // namespace formfactor::testing
