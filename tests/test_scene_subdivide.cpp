#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {
Scene one_surface(Polygon p, bool obstruction = false) {
    Scene s;
    s.materials.push_back(Material{});
    Surface x;
    x.name = "s";
    x.polygon = std::move(p);
    x.obstruction = obstruction;
    s.surfaces.push_back(x);
    return s;
}
double patch_area_of(const Scene& s, int surface) {
    double a = 0.0;
    for (const Patch& p : s.patches)
        if (p.surface == surface) a += p.area;
    return a;
}
std::string option_error(Scene& s, SubdivisionOptions o) {
    try {
        subdivide(s, o);
    } catch (const OptionError& e) {
        return e.what();
    }
    return "";
}
// A planar, convex, non-parallelogram quad, tilted out of the axis planes.
Polygon trapezoid() {
    const Mat3 R = (Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized())).toRotationMatrix();
    Polygon p{{Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(3, 2, 0), Vec3(0.5, 3, 0)}};
    for (Vec3& v : p.vertices) v = R * v + Vec3(10, -3, 7);
    return p;
}
}  // namespace

TEST_CASE("scene: subdivide n×n keeps area, orientation and row-major order of a quad") {
    Scene s = one_surface(trapezoid());
    const Vec3 n0 = normal(s.surfaces[0].polygon);
    const double a0 = area(s.surfaces[0].polygon);
    for (int n : {1, 2, 3, 7}) {
        subdivide(s, {n, 0.0});
        REQUIRE(s.patches.size() == static_cast<std::size_t>(n * n));
        CHECK(patch_area_of(s, 0) == doctest::Approx(a0).epsilon(1e-13));
        for (const Patch& p : s.patches) {
            CHECK(p.surface == 0);
            CHECK((p.normal - n0).norm() < 1e-12);
            CHECK(planarity_defect(p.polygon) < 1e-12);
        }
        // Row-major: index r*n + c has its first vertex at P(c/n, r/n).
        const Polygon& q = s.surfaces[0].polygon;
        for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) {
                const double u = double(c) / n, v = double(r) / n;
                const Vec3 P = (1 - u) * (1 - v) * q[0] + u * (1 - v) * q[1] + u * v * q[2] +
                               (1 - u) * v * q[3];
                CHECK((s.patches[static_cast<std::size_t>(r * n + c)].polygon[0] - P).norm() <
                      1e-12);
            }
        // Corners are the surface's own vertices, exactly.
        CHECK(s.patches.front().polygon[0] == q[0]);
        CHECK(s.patches.back().polygon[2] == q[2]);
    }
}

TEST_CASE("scene: subdivide triangles into n² congruent triangles in a stable order") {
    Polygon t{{Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(0, 1, 1)}};
    Scene s = one_surface(t);
    subdivide(s, {3, 0.0});
    REQUIRE(s.patches.size() == 9);
    for (const Patch& p : s.patches) {
        CHECK(p.area == doctest::Approx(area(t) / 9).epsilon(1e-13));
        CHECK((p.normal - normal(t)).norm() < 1e-13);
    }
    // Row 0: up, down, up, down, up; row 1: up, down, up; row 2: up.
    CHECK((s.patches[0].polygon[0] - t[0]).norm() == 0.0);
    CHECK((s.patches[1].polygon[0] - (t[0] + (t[1] - t[0]) / 3)).norm() < 1e-15);
    CHECK((s.patches[4].polygon[1] - t[1]).norm() == 0.0);
    CHECK((s.patches[8].polygon[2] - t[2]).norm() == 0.0);
}

TEST_CASE("scene: subdivide other polygons through triangulation, n = 1 keeps them whole") {
    Polygon ell{
        {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}};
    Scene s = one_surface(ell);
    subdivide(s, {1, 0.0});
    REQUIRE(s.patches.size() == 1);
    CHECK(s.patches[0].polygon.size() == 6);
    subdivide(s, {2, 0.0});
    CHECK(s.patches.size() == 4 * 4);  // 4 triangles × 4
    CHECK(patch_area_of(s, 0) == doctest::Approx(3.0).epsilon(1e-14));
    for (const Patch& p : s.patches) CHECK(p.normal.z() == doctest::Approx(1.0));
}

TEST_CASE("scene: subdivide by max edge bounds every edge") {
    Scene s = one_surface(trapezoid());
    s.surfaces.push_back(s.surfaces[0]);
    s.surfaces[1].polygon = Polygon{{Vec3(0, 0, 0), Vec3(3, 0, 0), Vec3(0, 1, 0)}};
    s.surfaces.push_back(s.surfaces[0]);
    s.surfaces[2].obstruction = true;  // skipped
    subdivide(s, {1, 0.7});
    // Quad: |v0v1| = 4, |v3v2| = |(2.5, -1)| → n_u = ceil(4/0.7) = 6; |v0v3| = |(0.5,3)|,
    // |v1v2| = |(-1, 2)| → n_v = ceil(3.0414/0.7) = 5. Triangle: ceil(3.1623/0.7) = 5 → 25.
    std::size_t quads = 0, tris = 0;
    for (const Patch& p : s.patches) {
        CHECK(max_edge_length(p.polygon) <= 0.7 + 1e-12);
        (p.surface == 0 ? quads : tris) += 1;
        CHECK(p.surface != 2);
    }
    CHECK(quads == 30);
    CHECK(tris == 25);
    CHECK(patch_area_of(s, 0) == doctest::Approx(area(s.surfaces[0].polygon)).epsilon(1e-13));
    CHECK(patch_area_of(s, 1) == doctest::Approx(1.5).epsilon(1e-13));
    // Patches are consecutive per surface, in surface order.
    for (std::size_t k = 1; k < s.patches.size(); ++k)
        CHECK(s.patches[k].surface >= s.patches[k - 1].surface);
}

TEST_CASE("scene: subdivide refuses bad options with the option's name") {
    Scene s = builtin_scene("cube");
    CHECK(option_error(s, {0, 0.0}) == "subdivide: must be at least 1 (got 0)");
    CHECK(option_error(s, {-3, 0.0}).rfind("subdivide:", 0) == 0);
    CHECK(option_error(s, {1, -1.0}).rfind("max_edge: must be a positive length", 0) == 0);
    CHECK(option_error(s, {1, std::numeric_limits<double>::quiet_NaN()})
              .rfind("max_edge: must be a positive length", 0) == 0);
    CHECK(option_error(s, {1, std::numeric_limits<double>::infinity()}).rfind("max_edge:", 0) == 0);
    CHECK(option_error(s, {4, 0.5}) == "max_edge: cannot be combined with a subdivision n > 1");
    CHECK(option_error(s, {100000, 0.0}).rfind("subdivide: would make 6e+10 patches", 0) == 0);
    CHECK(option_error(s, {1, 1e-300}).rfind("max_edge: would make", 0) == 0);
    CHECK(s.patches.size() == 6);  // untouched by the refusals
    CHECK(option_error(s, {2, 0.0}) == "");
    CHECK(s.patches.size() == 24);
    CHECK(s.total_patch_area() == doctest::Approx(6.0).epsilon(1e-15));
}

TEST_CASE("scene: Cornell box subdivided keeps its area") {
    Scene s = builtin_scene("cornell");
    const double a = s.total_patch_area();
    subdivide(s, {1, 50.0});
    CHECK(s.total_patch_area() == doctest::Approx(a).epsilon(1e-12));
    for (const Patch& p : s.patches) CHECK(max_edge_length(p.polygon) <= 50.0 + 1e-9);
    CHECK(s.patches.size() > 1000);
}
