#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include "formfactor/pipeline.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "support/files.h"
#include "support/matrix_checks.h"
#include "support/scenes.h"

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::input_error;
using formfactor::testing::same_cycle;
using formfactor::testing::write_file;

namespace {
std::string vs3_error(const std::string& name, const std::string& text) {
    const std::string p = write_file(name, text);
    const std::string m = input_error([&] { load_scene(p); });
    const std::string dir = formfactor::testing::scratch_dir().string() + "/";
    return m.rfind(dir, 0) == 0 ? m.substr(dir.size()) : m;
}
const std::string kHead = "T test\nF 3\nV 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\n";  // lines 1-6
}  // namespace

TEST_CASE("scene: VS3 cube from View3D's manual") {
    const Scene s = load_scene(data("cube.vs3"));
    CHECK(s.title == "A simple cube (View3D manual example)");
    CHECK(s.enclosure);
    REQUIRE(s.vs3_control.has_value());
    CHECK(s.vs3_control->encl == 1);
    CHECK(s.vs3_control->list == 3);
    REQUIRE(s.warnings.size() == 1);
    CHECK(s.warnings[0].find("cube.vs3:2: control list has no meaning") != std::string::npos);
    REQUIRE(s.surfaces.size() == 6);
    CHECK(s.total_patch_area() == doctest::Approx(6.0).epsilon(1e-15));
    const Vec3 mid(0.5, 0.5, 0.5);
    for (const Surface& x : s.surfaces) {
        CHECK(plane_of(x.polygon).signed_distance(mid) == doctest::Approx(0.5));  // inward
        CHECK(s.materials[static_cast<std::size_t>(x.material)].emissivity == 0.5);
        CHECK(s.materials[static_cast<std::size_t>(x.material)].name == x.name);
    }
    CHECK(s.surfaces[0].name == "zeq0");
    CHECK(s.surfaces[3].where.line == 17);
}

TEST_CASE("scene: VS3 cube gives the matrix of the same cube built in memory, to 1e-12") {
    const Scene s = load_scene(data("cube.vs3"));
    const Scene cube = testing::unit_cube(1);
    testing::check_same_matrix_up_to_order(s, compute_form_factors(s).form_factors.F, cube,
                                           compute_form_factors(cube).form_factors.F, 1e-12);
}

TEST_CASE("scene: VS3 with comments, obstructions, a subsurface and text after the end") {
    const Scene s = load_scene(data("obstructed.vs3"));
    REQUIRE(s.surfaces.size() == 5);
    CHECK_FALSE(s.enclosure);
    CHECK(s.vs3_control->eps == 1e-4);
    CHECK(s.vs3_control->maxU == 8);
    CHECK(s.surfaces[1].name == "top");
    CHECK(s.materials[1].emissivity == 0.8);
    CHECK(s.materials[1].reflectance == Rgb::Constant(1.0 - 0.8));
    CHECK(s.surfaces[2].base == 0);  // window on bottom
    CHECK(s.surfaces[2].polygon.size() == 3);
    CHECK(s.surfaces[3].obstruction);
    CHECK(s.surfaces[4].obstruction);
    CHECK(s.surfaces[3].name == "obstruction-4");
    CHECK(s.surfaces[4].name == "plate-down");
    CHECK(s.obstruction_count() == 2);
    // The bottom minus its triangular window (which touches the bottom's edge) is cut into 2
    // convex pieces: 2 + top + window.
    CHECK(s.patches.size() == 4);
    REQUIRE(s.surfaces[0].holes.size() == 1);
    CHECK(s.total_patch_area() == doctest::Approx(2.0).epsilon(1e-15));
    CHECK((normal(s.surfaces[4].polygon) - Vec3(0, 0, -1)).norm() == 0.0);
    // Warnings: ignored controls (naming them); subsurfaces are applied (no warning).
    REQUIRE(s.warnings.size() == 1);
    CHECK(s.warnings[0].find(":3: control maxU, maxO, mino, list have no meaning") !=
          std::string::npos);
}

TEST_CASE("scene: VS3 F 3a (origin, azimuth, tilt) gives View3D's F 3 geometry") {
    const Scene a = load_scene(data("lshape-3.vs3"));
    const Scene b = load_scene(data("lshape-3a.vs3"));
    REQUIRE(a.surfaces.size() == 12);
    REQUIRE(b.surfaces.size() == 12);
    for (std::size_t k = 0; k < 12; ++k) {
        CHECK_MESSAGE(same_cycle(a.surfaces[k].polygon, b.surfaces[k].polygon), "surface ", k + 1);
        CHECK(a.surfaces[k].combine == b.surfaces[k].combine);
    }
    CHECK(a.surfaces[8].combine == 6);
    CHECK(a.surfaces[11].combine == 7);
    CHECK(a.enclosure);
    CHECK(b.vs3_control->eps == 1e-5);
    CHECK(a.vs3_control->emit == 1);
    // The L-shaped room: floor and ceiling 5 m² each, walls 3 m high around a 12 m perimeter.
    CHECK(a.total_patch_area() == doctest::Approx(46.0).epsilon(1e-14));
    CHECK(b.total_patch_area() == doctest::Approx(46.0).epsilon(1e-14));
}

TEST_CASE("scene: VS3 error messages name file, line and reason") {
    CHECK(vs3_error("a.vs3", kHead + "Q 1 2 3\n") == "a.vs3:7: unknown record 'Q'");
    CHECK(vs3_error("b.vs3", kHead + "S 1 1 2 3 4 0 0 abc floor\n") ==
          "b.vs3:7: malformed number 'abc' in S record");
    CHECK(vs3_error("c.vs3", "F 3\nV 1 0 0 x\n") == "c.vs3:2: malformed number 'x' in V record");
    CHECK(vs3_error("d.vs3", kHead + "S 1 1 2 3 9 0 0 0.9 floor\n") ==
          "d.vs3:7: surface 1: vertex 9 does not exist (the file defines 4 vertices)");
    CHECK(vs3_error("e.vs3", kHead + "S 1 1 2 3 4 0 0 0.9\n") ==
          "e.vs3:7: S record has 8 fields (9 needed: number, v1, v2, v3, v4, base, cmb, emit, "
          "name)");
    CHECK(vs3_error("f.vs3", kHead + "V 4 0 0 1\n") ==
          "f.vs3:7: vertex 4 defined twice (first at line 6)");
    CHECK(vs3_error("g.vs3", kHead + "V 6 0 0 1\n")
              .rfind("g.vs3:7: vertex 6 out of sequence (expected 5", 0) == 0);
    CHECK(vs3_error("h.vs3", kHead + "S 1 1 2 3 4 0 0 0.9 a\nS 1 1 2 3 4 0 0 0.9 b\n") ==
          "h.vs3:8: surface 1 defined twice (first at line 7)");
    CHECK(vs3_error("i.vs3", kHead + "V 5 0.5 0.5 0.2\nS 1 1 2 3 5 0 0 0.9 a\n")
              .rfind("i.vs3:8: surface 1 is not planar (defect ", 0) == 0);
    CHECK(vs3_error("k.vs3", kHead + "V 5 2 0 0\nS 1 1 2 5 0 0 0 0.9 a\n")
              .rfind("k.vs3:8: surface 1 is degenerate", 0) == 0);
    CHECK(vs3_error("l.vs3", "F 3\nV 1 0 0 nan\n") ==
          "l.vs3:2: number 'nan' in V record is not finite");
    CHECK(vs3_error("m.vs3", kHead + "S 1 1 2 3 4 0 0 1.5 a\n") ==
          "m.vs3:7: emissivity 1.5 of surface 1 is outside [0, 1]");
    CHECK(vs3_error("n.vs3", kHead + "M 1 4 3 2 1 1 0 0.9 mask\n")
              .rfind("n.vs3:7: masking surfaces (M records) are not supported yet", 0) == 0);
    CHECK(vs3_error("o.vs3", kHead + "N 1 4 3 2 1 1 0 0.9 null\n")
              .rfind("o.vs3:7: null surfaces (N records) are not supported yet", 0) == 0);
    CHECK(vs3_error("p.vs3", "F 2\n") ==
          "p.vs3:1: geometry format 'F 2' is not supported (View3D 3.2 reads 3 and 3a)");
    CHECK(vs3_error("q.vs3", kHead + "S 1 1 2 3 4 0 0 0.9 a\nS 2 1 2 3 4 0 1 0.9 b\n") == "");
    CHECK(vs3_error("r.vs3", kHead + "S 1 1 2 3 4 2 0 0.9 a\nS 2 1 2 3 4 0 0 0.9 b\n") ==
          "r.vs3:7: surface 1: base surface 2 must come before its subsurface");
    CHECK(vs3_error("s.vs3", kHead + "V 5 0 0 1\nS 1 1 2 3 4 0 0 0.9 a\nS 2 1 2 5 0 1 0 0.9 b\n") ==
          "s.vs3:9: surface 2 is not in the plane of its base surface 1 (distance 1)");
    CHECK(vs3_error("t.vs3", kHead + "V 5 3 0 0\nS 1 1 2 3 4 0 0 0.9 a\nS 2 1 5 3 0 1 0 0.9 b\n") ==
          "t.vs3:9: surface 2 is not entirely within its base surface 1");
    CHECK(vs3_error("u.vs3", kHead + "S 1 1 2 3 4 0 0 0.9 a\nS 2 1 2 3 4 0 2 0.9 b\n") ==
          "u.vs3:8: surface 2: must combine with a previous surface (cmb 2)");
    CHECK(vs3_error("v.vs3", "F 3a\nS 1 R 0 0 0.9 a\n 0 0 0 0 90 1\nS 2 R 0 0 0.9 b\n")
              .rfind("v.vs3:4: surface 1 (R) needs 7 numbers after line 2; found 6", 0) == 0);
    CHECK(vs3_error("w.vs3", "F 3a\nS 1 X 0 0 0.9 a\n") ==
          "w.vs3:2: invalid shape 'X' of surface 1 (R rectangle, T triangle or Q quadrilateral)");
    CHECK(vs3_error("x.vs3", kHead + "S 1 1 2 3 0 0 0 0.9 a\nV 5 1 1 1\n") == "");
}

TEST_CASE("scene: VS3 round trip keeps surfaces, obstruction flags and emissivities") {
    for (const std::string& name :
         {data("obstructed.vs3"), data("lshape-3.vs3"), std::string("cube")}) {
        const Scene a = load_scene(name);
        const std::string out = (formfactor::testing::scratch_dir() / "rt.vs3").string();
        save_vs3(a, out);
        CHECK_FALSE(std::filesystem::exists(out + ".tmp"));
        const Scene b = load_scene(out);
        REQUIRE(a.surfaces.size() == b.surfaces.size());
        CHECK(a.enclosure == b.enclosure);
        for (std::size_t k = 0; k < a.surfaces.size(); ++k) {
            const Surface& x = a.surfaces[k];
            const Surface& y = b.surfaces[k];
            CHECK(x.polygon.vertices == y.polygon.vertices);
            CHECK(x.obstruction == y.obstruction);
            CHECK(x.base == y.base);
            CHECK(x.combine == y.combine);
            CHECK(x.name == y.name);
            CHECK(a.materials[static_cast<std::size_t>(x.material)].emissivity ==
                  b.materials[static_cast<std::size_t>(y.material)].emissivity);
        }
    }
}

TEST_CASE("scene: VS3 writer puts obstructions last and splits what View3D cannot take") {
    const Scene a = load_scene(data("room.obj"));  // quad, quad, obstruction triangle
    Scene c = a;
    // Move the obstruction first and add a pentagon.
    std::swap(c.surfaces[0], c.surfaces[2]);
    Surface pent = c.surfaces[1];
    pent.name = "pent";
    pent.polygon =
        Polygon{{Vec3(0, 0, 3), Vec3(2, 0, 3), Vec3(2, 1, 3), Vec3(1, 2, 3), Vec3(0, 1, 3)}};
    c.surfaces.push_back(pent);
    const std::string out = (formfactor::testing::scratch_dir() / "split.vs3").string();
    save_vs3(c, out);
    const Scene b = load_scene(out);
    REQUIRE(b.surfaces.size() == 6);  // 2 quads + 3 pentagon triangles + obstruction
    CHECK(b.surfaces[0].polygon.vertices == c.surfaces[1].polygon.vertices);
    CHECK(b.surfaces[5].obstruction);
    CHECK(b.surfaces[5].polygon.vertices == c.surfaces[0].polygon.vertices);
    CHECK(b.surfaces[2].combine == -1);
    CHECK(b.surfaces[3].combine == 2);
    CHECK(b.surfaces[4].combine == 2);
    CHECK(area(b.surfaces[2].polygon) + area(b.surfaces[3].polygon) + area(b.surfaces[4].polygon) ==
          doctest::Approx(area(pent.polygon)).epsilon(1e-14));
}

TEST_CASE("scene: a VS3 file without S records is an input error") {
    CHECK(vs3_error("none.vs3", kHead + "End of data\n") ==
          "none.vs3: the scene is empty: no surfaces (S records), nothing to compute");
    CHECK(vs3_error("only_o.vs3", kHead + "O 1 1 2 3 4 0 0 0 panel\nEnd of data\n") ==
          "only_o.vs3: all 1 surfaces are obstructions: there are no surfaces to compute form "
          "factors between (S records have rows, O records only block)");
}
