#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <string>

#include "formfactor/scene/scene.h"
#include "support/files.h"

using namespace formfactor;
using formfactor::testing::input_error;

namespace {
std::string check(const Polygon& p, const std::string& what = "face") {
    return input_error([&] { validate_polygon(p, {"room.obj", 12}, what); });
}
Polygon square() { return Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}}; }
}  // namespace

TEST_CASE("scene: validate_polygon accepts good polygons, collinear vertices included") {
    CHECK(check(square()) == "");
    // A square with an extra vertex in the middle of an edge: harmless.
    CHECK(check(Polygon{{Vec3(0, 0, 0), Vec3(0.5, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0),
                         Vec3(0, 1, 0)}}) == "");
    // Non-convex L shape, far from the origin.
    CHECK(check(Polygon{{Vec3(1e4, 0, 0), Vec3(1e4 + 2, 0, 0), Vec3(1e4 + 2, 1, 0),
                         Vec3(1e4 + 1, 1, 0), Vec3(1e4 + 1, 2, 0), Vec3(1e4, 2, 0)}}) == "");
}

TEST_CASE("scene: validate_polygon reports each defect with file, line and reason") {
    CHECK(check(Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0)}}) ==
          "room.obj:12: face has 2 vertices (at least 3 needed)");
    Polygon nan = square();
    nan[2].y() = std::numeric_limits<double>::quiet_NaN();
    CHECK(check(nan).rfind("room.obj:12: face has a coordinate that is not finite (vertex 3", 0) ==
          0);
    Polygon inf = square();
    inf[0].z() = std::numeric_limits<double>::infinity();
    CHECK(check(inf).find("not finite (vertex 1") != std::string::npos);
    Polygon rep{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}};
    CHECK(check(rep) == "room.obj:12: face has a zero-length edge (vertices 2 and 3 coincide)");
    Polygon flat{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)}};
    CHECK(check(flat).rfind("room.obj:12: face is degenerate (zero area", 0) == 0);
    Polygon bent = square();
    bent[2].z() = 2.1e-3 * std::sqrt(2.0) * 2;  // well beyond tolerance
    const std::string m = check(bent, "surface 3");
    CHECK(m.rfind("room.obj:12: surface 3 is not planar (defect ", 0) == 0);
    CHECK(m.find("of its size, tolerance 1e-06)") != std::string::npos);
    Polygon bow{{Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}};
    CHECK(check(bow) == "room.obj:12: face is not simple (its edges cross or touch)");
}

TEST_CASE("scene: planarity tolerance is relative to the polygon's size") {
    // The same tiny relative defect passes at any scale; a larger one fails at any scale.
    for (double scale : {1e-3, 1.0, 1e4}) {
        Polygon ok = square();
        for (Vec3& v : ok.vertices) v *= scale;
        ok[2].z() = 1e-7 * scale;
        CHECK(check(ok) == "");
        Polygon bad = ok;
        bad[2].z() = 1e-5 * scale;
        CHECK(check(bad).find("is not planar") != std::string::npos);
    }
}

TEST_CASE("scene: load_scene reports a missing file, an unknown extension or built-in name") {
    CHECK(input_error([] { load_scene("/nonexistent/room.obj"); }) ==
          "/nonexistent/room.obj: cannot open file");
    CHECK(input_error([] { load_scene("/nonexistent/room.vs3"); }) ==
          "/nonexistent/room.vs3: cannot open file");
    CHECK(input_error([] {
              load_scene("room.dxf");
          }).rfind("room.dxf: unknown file extension '.dxf' (", 0) == 0);
    CHECK(input_error([] { load_scene("cornel"); })
              .rfind("cornel: not a built-in scene (cornell, cornell-empty, plates, "
                     "perpendicular, cube)",
                     0) == 0);
    CHECK(input_error([] { builtin_scene("box"); }).rfind("box: unknown built-in scene", 0) == 0);
    CHECK(input_error([] {
              load_scene(formfactor::testing::scratch_dir().string() + "/x.OBJ");
          }).find("cannot open file") != std::string::npos);
}
