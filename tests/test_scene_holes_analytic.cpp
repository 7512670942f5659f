// Surfaces with holes and per-surface aggregation, checked with the exact analytic method:
// form factors are additive over exact tilings, so cutting windows out of walls must not
// change any sum.

#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "formfactor/kernels/analytic.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"
#include "support/files.h"
#include "support/matrix_checks.h"
#include "support/method_runner.h"

using formfactor::testing::check_enclosure_rows;
using formfactor::testing::check_row_sums;
using formfactor::testing::tight_analytic;

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::write_file;

namespace {

// The unit cube, View3D's catalog values (tests/reference catalog, exact closed forms).
constexpr double kOpposite = 0.19982489569838746;
constexpr double kAdjacent = 0.20004377607540316;

// Checks a 6 × 6 matrix against the cube's (faces x=0, x=1, y=0, y=1, z=0, z=1).
void check_cube(const FormFactors& f, double tol) {
    REQUIRE(f.size() == 6);
    for (Eigen::Index i = 0; i < 6; ++i) {
        CHECK(std::abs(f.areas[static_cast<std::size_t>(i)] - 1.0) <= 1e-13);
        for (Eigen::Index j = 0; j < 6; ++j) {
            const double expected = i == j ? 0.0 : (i / 2 == j / 2 ? kOpposite : kAdjacent);
            CHECK_MESSAGE(std::abs(f.F(i, j) - expected) <= tol, "F(", i, ",", j,
                          ") = ", f.F(i, j));
        }
    }
}

// The cube as a VS3 file whose z = 1 face is split (text after the S records of 5 faces).
const std::string kCubeHead =
    "T cube\nC encl=1\nF 3\n"
    "V 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\nV 5 0 0 1\nV 6 1 0 1\nV 7 1 1 1\nV 8 0 1 1\n"
    "S 1 1 4 8 5 0 0 0.9 x0\n"   // faces +x
    "S 2 2 6 7 3 0 0 0.9 x1\n"   // faces -x
    "S 3 1 5 6 2 0 0 0.9 y0\n"   // faces +y
    "S 4 4 3 7 8 0 0 0.9 y1\n"   // faces -y
    "S 5 1 2 3 4 0 0 0.9 z0\n";  // faces +z

}  // namespace

TEST_CASE("scene: wall minus window plus window gives the whole wall (analytic, exact)") {
    Scene s = load_scene(data("room-windows.vs3"));
    const FormFactors f = tight_analytic(s);
    const FormFactors g = aggregate_per_surface(s, f);
    REQUIRE(g.size() == 12);
    const Polygon& floor = s.surfaces[0].polygon;
    // Floor → south: the wall minus window, the window minus pane, the pane.
    const double south = polygon_to_polygon(floor, s.surfaces[2].polygon);
    CHECK(std::abs(g.F(0, 2) + g.F(0, 6) + g.F(0, 7) - south) <= 1e-10);
    // The window itself, whole, is the window-minus-pane plus the pane.
    CHECK(std::abs(g.F(0, 6) + g.F(0, 7) - polygon_to_polygon(floor, s.surfaces[6].polygon)) <=
          1e-10);
    // West wall and the door that touches the floor's edge.
    CHECK(std::abs(g.F(0, 4) + g.F(0, 8) - polygon_to_polygon(floor, s.surfaces[4].polygon)) <=
          1e-10);
    // North wall and its three windows (two sharing an edge, one in the corner).
    CHECK(std::abs(g.F(0, 3) + g.F(0, 9) + g.F(0, 10) + g.F(0, 11) -
                   polygon_to_polygon(floor, s.surfaces[3].polygon)) <= 1e-10);
    // Closed room: every surface row sums to 1; reciprocity at the surface level.
    REQUIRE(g.size() == 12);
    check_enclosure_rows(g, 1e-10, 1e-10);
    // The areas are the surfaces minus their holes.
    CHECK(std::abs(g.areas[2] - 8.2) <= 1e-12 * 8.2);
    CHECK(std::abs(g.areas[6] - 0.92) <= 1e-12 * 0.92);
    // Subdivided, the per-surface matrix is the same (additivity over any exact tiling).
    subdivide(s, {3, 0.0});
    const FormFactors g3 = aggregate_per_surface(s, tight_analytic(s));
    CHECK((g3.F - g.F).cwiseAbs().maxCoeff() <= 1e-10);
}

TEST_CASE("scene: cube with a subsurface in one face, cube subdivided n = 4 (per surface)") {
    SUBCASE("face z = 1 as a base with a window: rows sum to 1, base + window = the face") {
        const std::string text = kCubeHead +
                                 "V 9 0.2 0.3 1\nV 10 0.7 0.3 1\nV 11 0.7 0.9 1\nV 12 0.2 0.9 1\n"
                                 "S 6 5 8 7 6 0 0 0.9 z1\n"  // faces -z
                                 "S 7 9 12 11 10 6 0 0.9 z1-window\n"
                                 "End\n";
        const Scene s = load_scene(write_file("cube-window.vs3", text));
        REQUIRE(s.surfaces[5].holes.size() == 1);
        const FormFactors f = tight_analytic(s);
        check_row_sums(f.F, 1.0, 1e-10);
        FormFactors g = aggregate_per_surface(s, f);
        REQUIRE(g.size() == 7);
        CHECK(std::abs(g.areas[5] - (1.0 - 0.3)) <= 1e-13);
        CHECK(std::abs(g.areas[6] - 0.3) <= 1e-13);
        check_row_sums(g.F, 1.0, 1e-10);
        // Base and window together are the cube's face: F from the other faces adds up.
        for (Eigen::Index i = 0; i < 5; ++i) {
            const double expected = i == 4 ? kOpposite : kAdjacent;
            CHECK(std::abs(g.F(i, 5) + g.F(i, 6) - expected) <= 1e-10);
        }
        // Combining the window with its base (cmb) gives back the plain cube.
        Scene c = s;
        c.surfaces[6].combine = 5;
        check_cube(aggregate_per_surface(c, f), 1e-10);
    }
    SUBCASE("cube subdivided n = 4, aggregated per surface, is the cube") {
        Scene s = load_scene("cube");
        subdivide(s, {4, 0.0});
        REQUIRE(s.patches.size() == 96);
        check_cube(aggregate_per_surface(s, tight_analytic(s)), 1e-10);
    }
}

TEST_CASE("scene: combined surfaces (cmb) merge rows and columns as View3D's Combine") {
    // Face z = 1 drawn as two rectangles, the second combined with the first.
    const std::string text = kCubeHead +
                             "V 9 0.4 0 1\nV 10 0.4 1 1\n"
                             "S 6 5 8 10 9 0 0 0.9 z1\n"       // x in [0, 0.4]
                             "S 7 9 10 7 6 0 6 0.9 z1-rest\n"  // x in [0.4, 1], cmb 6
                             "End\n";
    Scene s = load_scene(write_file("cube-cmb.vs3", text));
    CHECK(s.warnings.empty());
    REQUIRE(s.surfaces[6].combine == 5);
    const FormFactors f = tight_analytic(s);
    const FormFactors g = aggregate_per_surface(s, f);
    check_cube(g, 1e-10);
    // The same, computed by hand from the patch matrix: row z1 = (A_a F_a· + A_b F_b·)/(A_a+A_b).
    const double merged = (0.4 * (f.F(5, 0)) + 0.6 * (f.F(6, 0))) / 1.0;
    CHECK(std::abs(g.F(5, 0) - merged) <= 1e-14);
    CHECK(std::abs(g.F(0, 5) - (f.F(0, 5) + f.F(0, 6))) <= 1e-14);
    // And subdivided n = 3 it is still the cube.
    subdivide(s, {3, 0.0});
    check_cube(aggregate_per_surface(s, tight_analytic(s)), 1e-10);
}
