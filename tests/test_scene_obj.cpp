#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "support/files.h"

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::input_error;
using formfactor::testing::write_file;

namespace {
std::string obj_error(const std::string& name, const std::string& text) {
    const std::string p = write_file(name, text);
    const std::string m = input_error([&] { load_scene(p); });
    // Strip the folder: messages start with the path.
    const std::string dir = formfactor::testing::scratch_dir().string() + "/";
    return m.rfind(dir, 0) == 0 ? m.substr(dir.size()) : m;
}
const std::string kVerts = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
}  // namespace

TEST_CASE("scene: OBJ room with groups, obstruction group, MTL Kd/Ke and thermal keys") {
    const Scene s = load_scene(data("room.obj"));
    REQUIRE(s.surfaces.size() == 3);
    CHECK(s.surfaces[0].name == "floor");
    CHECK(s.surfaces[1].name == "wall");
    CHECK(s.surfaces[2].name == "obstruction_panel");
    CHECK_FALSE(s.surfaces[0].obstruction);
    CHECK_FALSE(s.surfaces[1].obstruction);
    CHECK(s.surfaces[2].obstruction);
    CHECK(s.obstruction_count() == 1);
    CHECK(s.surfaces[0].where.line == 14);
    CHECK(s.surfaces[1].where.line == 17);
    CHECK(s.surfaces[2].where.line == 24);
    REQUIRE(s.patches.size() == 2);
    CHECK(s.patches[0].area == 4.0);
    CHECK((s.patches[0].normal - Vec3(0, 0, 1)).norm() == 0.0);
    CHECK((s.patches[1].normal - Vec3(0, 1, 0)).norm() == 0.0);  // f 1 5 6 2 faces +y
    // Relative indices: the panel is the last three vertices.
    CHECK(s.surfaces[2].polygon[0] == Vec3(1, 1, 0.5));
    const Material& white = s.materials[static_cast<std::size_t>(s.surfaces[0].material)];
    CHECK(white.name == "white");
    CHECK(white.reflectance == Rgb(0.8, 0.7, 0.6));
    CHECK(white.emission == Rgb::Zero());
    CHECK(white.emissivity == 0.85);
    CHECK(std::isnan(white.temperature));
    const Material& lamp = s.materials[static_cast<std::size_t>(s.surfaces[1].material)];
    CHECK(lamp.reflectance == Rgb::Constant(0.5));  // `Kd 0.5` is grey, not (0.5, 0, 0)
    CHECK(lamp.emission == Rgb(10, 9, 8));
    CHECK(lamp.temperature == 350.0);
    CHECK(s.warnings.empty());
}

TEST_CASE("scene: OBJ error messages name file and line") {
    CHECK(obj_error("a.obj", "v 1 2 x\n") == "a.obj:1: malformed number 'x' in v record");
    CHECK(obj_error("b.obj", "v 1 2\n") == "b.obj:1: v record has 2 numbers (x, y, z needed)");
    CHECK(obj_error("c.obj", kVerts + "f 1 2\n") ==
          "c.obj:5: face has 2 vertices (at least 3 needed)");
    CHECK(obj_error("d.obj", kVerts + "f 1 2 9\n") ==
          "d.obj:5: face vertex index 9 out of range (the file has 4 vertices)");
    CHECK(obj_error("e.obj", kVerts + "f 0 1 2\n") ==
          "e.obj:5: vertex index 0 is invalid (OBJ indices start at 1)");
    CHECK(obj_error("f.obj", kVerts + "f -5 1 2\n")
              .rfind("f.obj:5: relative vertex index -5 points before the first one", 0) == 0);
    CHECK(obj_error("g.obj", kVerts + "f 1 2 3a\n") ==
          "g.obj:5: malformed vertex index '3a' in f record");
    CHECK(obj_error("h.obj", "v 0 0 0\nv nan 0 0\n") ==
          "h.obj:2: vertex coordinate 'nan' is not finite");
    CHECK(obj_error("i.obj", "v 0 0 0\nv inf 0 0\n") ==
          "i.obj:2: vertex coordinate 'inf' is not finite");
    CHECK(obj_error("j.obj", kVerts + "f 1 2 3 3\n") ==
          "j.obj:5: face has a zero-length edge (vertices 3 and 4 coincide)");
    CHECK(obj_error("k.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
              .rfind("k.obj:4: face is degenerate", 0) == 0);
    CHECK(obj_error("l.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.1\nv 0 1 0\nf 1 2 3 4\n")
              .rfind("l.obj:5: face is not planar (defect ", 0) == 0);
    CHECK(obj_error("m.obj", kVerts + "# comment\n\nf 1 3 2 4\n") ==
          "m.obj:7: face is not simple (its edges cross or touch)");
}

TEST_CASE("scene: OBJ warnings for ignored records and a missing material library") {
    const std::string p = write_file(
        "w.obj", "mtllib nowhere.mtl\n" + kVerts + "vn 0 0 1\nl 1 2\np 3\nusemtl red\nf 1 2 3 4\n");
    const Scene s = load_scene(p);
    REQUIRE(s.surfaces.size() == 1);
    CHECK(s.surfaces[0].name == "face");
    REQUIRE(s.warnings.size() == 3);
    CHECK(s.warnings[0].find("w.obj:1: cannot open material library") != std::string::npos);
    CHECK(s.warnings[1].find("w.obj:7: lines (l records) ignored") != std::string::npos);
    CHECK(s.warnings[2].find("w.obj:8: points (p records) ignored") != std::string::npos);
    CHECK(s.materials[static_cast<std::size_t>(s.surfaces[0].material)].name == "default");
}

TEST_CASE("scene: OBJ faces of one group are numbered, objects named obstruction* block") {
    const std::string p = write_file(
        "g.obj", kVerts +
                     "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\no Obstruction-lid\nf 5 8 7 6\nf 5 6 7\n"
                     "o box\ng a\nf 1 2 3\nf 1 3 4\ng\nf 1 2 4\n");
    const Scene s = load_scene(p);
    REQUIRE(s.surfaces.size() == 5);
    CHECK(s.surfaces[0].name == "Obstruction-lid.1");
    CHECK(s.surfaces[1].name == "Obstruction-lid.2");
    CHECK(s.surfaces[0].obstruction);
    CHECK(s.surfaces[1].obstruction);
    CHECK(s.surfaces[2].name == "a.1");
    CHECK(s.surfaces[3].name == "a.2");
    CHECK(s.surfaces[4].name == "box");
    CHECK_FALSE(s.surfaces[4].obstruction);
    CHECK(s.patches.size() == 3);
    CHECK(s.patches[0].surface == 2);
}

TEST_CASE("scene: OBJ MTL errors name the MTL file and line") {
    write_file("bad.mtl", "newmtl a\nKd 0.5 0.5 zz\n");
    CHECK(obj_error("bad.obj", "mtllib bad.mtl\n" + kVerts + "f 1 2 3\n") ==
          "bad.mtl:2: malformed number 'zz' in Kd record");
    write_file("bad2.mtl", "newmtl a\nKd 1.5 0.5 0.5\n");
    CHECK(obj_error("bad2.obj", "mtllib bad2.mtl\n" + kVerts + "f 1 2 3\n") ==
          "bad2.mtl:2: reflectance Kd must be within [0, 1]");
}

TEST_CASE("scene: OBJ round trip keeps surfaces, flags and materials") {
    for (const std::string& name : {std::string("cornell"), data("room.obj")}) {
        const Scene a = load_scene(name);
        const std::string out = (formfactor::testing::scratch_dir() / "rt.obj").string();
        save_obj(a, out);
        CHECK_FALSE(std::filesystem::exists(out + ".tmp"));
        const Scene b = load_scene(out);
        REQUIRE(a.surfaces.size() == b.surfaces.size());
        for (std::size_t k = 0; k < a.surfaces.size(); ++k) {
            const Surface& x = a.surfaces[k];
            const Surface& y = b.surfaces[k];
            CHECK(x.polygon.vertices == y.polygon.vertices);
            CHECK(x.obstruction == y.obstruction);
            CHECK(x.name == y.name.substr(y.name.size() - x.name.size()));
            const Material& mx = a.materials[static_cast<std::size_t>(x.material)];
            const Material& my = b.materials[static_cast<std::size_t>(y.material)];
            CHECK(mx.reflectance == my.reflectance);
            CHECK(mx.emission == my.emission);
            CHECK(mx.emissivity == my.emissivity);
            CHECK((mx.temperature == my.temperature ||
                   (std::isnan(mx.temperature) && std::isnan(my.temperature))));
        }
        CHECK(b.warnings.empty());
    }
}

TEST_CASE("scene: an OBJ without faces, or with obstruction faces only, is an input error") {
    CHECK(obj_error("none.obj", kVerts) ==
          "none.obj: the scene is empty: no faces (f records), nothing to compute");
    CHECK(obj_error("blocks.obj", kVerts + "o obstruction_box\nf 1 2 3 4\n") ==
          "blocks.obj: all 1 surfaces are obstructions: there are no surfaces to compute form "
          "factors between (faces outside groups and objects named obstruction* have rows)");
    CHECK(obj_error("ok.obj", kVerts + "g obstruction\nf 1 2 3 4\ng floor\nf 4 3 2 1\n").empty());
}

TEST_CASE("scene: OBJ coordinates are read correctly rounded, as in every other form") {
    // tinyobjloader's own number parser read "0.3" as 0.30000000000000004 and "0.7" as
    // 0.7000000000000001: the same geometry from an OBJ file and from a VS3 file or arrays then
    // differed in the last bit, and so did their form factors (by 3e-8 on an obstructed box).
    const std::string p = write_file("rounding.obj",
                                     "v 0.5 0.3 0.7\nv 1.4 0.3 0.7\nv 0.9 0.8 0.7\n"
                                     "v 1e-1 2.675 -0.1\nf 1 3 2\n");
    const Scene s = load_scene(p);
    REQUIRE(s.surfaces.size() == 1);
    const Polygon& q = s.surfaces[0].polygon;
    CHECK(q[0] == Vec3(0.5, 0.3, 0.7));
    CHECK(q[1] == Vec3(0.9, 0.8, 0.7));
    CHECK(q[2] == Vec3(1.4, 0.3, 0.7));
}
