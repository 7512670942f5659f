// STL (ASCII and binary), PLY, OFF and glTF 2.0 (.gltf, .glb) through Open Asset Import: files
// written here by an independent writer that follows each format's specification
// (tests/mesh_files.h), read by load_scene(), checked against the same geometry as OBJ.

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/mesh_io.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/files.h"
#include "support/mesh_files.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::input_error;
using namespace formfactor::testing;

namespace {

DenseMatrix patch_matrix(const Scene& s) { return compute_form_factors(s).form_factors.F; }

}  // namespace

TEST_CASE("mesh: a triangulated box as STL (ASCII, binary), PLY, OFF and glTF equals the OBJ") {
    const TempDir dir;
    const TestMesh quads = unit_box_quads("box");
    const TestMesh tris = triangulated(quads);
    write_text(dir.file("box.obj"), obj({tris}));
    write_text(dir.file("box-ascii.stl"), stl_ascii(tris));
    write_text(dir.file("box-binary.stl"), stl_binary(tris));
    write_text(dir.file("box-ascii.ply"), ply(tris, false));
    write_text(dir.file("box-binary.ply"), ply(tris, true));
    write_text(dir.file("box.off"), off(tris));
    GltfPart part;
    part.mesh = tris;
    write_text(dir.file("box.gltf"), gltf({part}, false));
    write_text(dir.file("box.glb"), gltf({part}, true));

    const Scene reference = load_scene(dir.file("box.obj"));
    REQUIRE(reference.patches.size() == 12);
    const DenseMatrix F0 = patch_matrix(reference);
    for (const char* name : {"box-ascii.stl", "box-binary.stl", "box-ascii.ply", "box-binary.ply",
                             "box.off", "box.gltf", "box.glb"}) {
        INFO(name);
        const Scene s = load_scene(dir.file(name));
        REQUIRE(s.surfaces.size() == 12);
        for (std::size_t k = 0; k < 12; ++k)
            CHECK(testing::same_cycle(s.surfaces[k].polygon, reference.surfaces[k].polygon, 0.0));
        // One surface group per mesh, named as the file names it (ASCII STL: `solid box`; glTF:
        // the node; files without names: the file's stem).
        const PatchGroups g = surface_groups(s);
        REQUIRE(g.size() == 1);
        const std::string stem = std::filesystem::path(name).stem().string();
        const bool named = std::string(name) == "box-ascii.stl" ||
                           std::string(name).find(".gl") != std::string::npos;
        CHECK(g.names[0] == (named ? "box" : stem));
        const DenseMatrix F = patch_matrix(s);
        CHECK((F - F0).cwiseAbs().maxCoeff() <= 1e-12);
    }
}

TEST_CASE("mesh: PLY and OFF polygons stay polygons") {
    const TempDir dir;
    const TestMesh quads = unit_box_quads("box");
    write_text(dir.file("q.ply"), ply(quads, true));
    write_text(dir.file("q.off"), off(quads));
    for (const char* name : {"q.ply", "q.off"}) {
        const Scene s = load_scene(dir.file(name));
        REQUIRE(s.surfaces.size() == 6);
        for (const Surface& x : s.surfaces) CHECK(x.polygon.size() == 4);
        double row = 0;
        const DenseMatrix F = patch_matrix(s);
        for (Eigen::Index j = 0; j < 6; ++j) row += F(0, j);
        CHECK(std::abs(row - 1.0) < 1e-9);  // a closed box
    }
}

TEST_CASE("mesh: glTF nodes are surfaces, translated, with base colour and emission") {
    const TempDir dir;
    GltfPart floor;
    floor.mesh = triangulated(unit_box_quads("floor"));
    floor.base_color = {0.25, 0.5, 0.75};
    GltfPart lamp;
    lamp.mesh = triangulated(unit_box_quads("lamp"));
    lamp.translation = Vec3(3, 0, 0.5);
    lamp.emissive = {1, 0.5, 0.25};
    for (bool glb : {false, true}) {
        const std::string path = dir.file(glb ? "two.glb" : "two.gltf");
        write_text(path, gltf({floor, lamp}, glb));
        const Scene s = load_scene(path);
        REQUIRE(s.surfaces.size() == 24);
        const PatchGroups g = surface_groups(s);
        CHECK(g.names == std::vector<std::string>{"floor", "lamp"});
        CHECK(s.surfaces[12].polygon[0].isApprox(Vec3(3, 0, 0.5)));
        const Material& a = s.material_of_surface(0);
        const Material& b = s.material_of_surface(12);
        CHECK(a.reflectance.isApprox(Rgb(0.25, 0.5, 0.75)));
        CHECK(a.emission.isZero());
        CHECK(b.emission.isApprox(Rgb(1, 0.5, 0.25)));
    }
}

TEST_CASE("mesh: the PLY and OFF checks take plain decimals as numbers, and nothing else") {
    for (const char* w : {"0", "-1", "+2.5", "1.", ".5", "1e-3", "2.5E+10", "-0.0e0"}) {
        CAPTURE(w);
        CHECK(formfactor::detail::is_plain_decimal(w));
    }
    for (const char* w : {"", "-", ".", "e5", "1e", "1e+", "1.5.2", "1,5", "0x1p3", "nan", "inf",
                          "-inf", "1x", "+-1", " 1", "1 "}) {
        CAPTURE(w);
        CHECK_FALSE(formfactor::detail::is_plain_decimal(w));
    }
}

TEST_CASE("mesh: an OFF file is refused where Open Asset Import would misread it") {
    // Its reader reads a blank or comment line among the vertices as a vertex at the origin, a
    // word that is not a number as 0, drops faces of 0 or more than 9 vertices (and crashed
    // when that left none), takes a vertex's first digits for a missing edges' count, and
    // copies a line into 4,096 bytes. Each is an error naming the line, before assimp reads.
    TempDir dir;
    const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
    struct Case {
        const char* what;
        std::string text;
        std::string message;
    };
    const std::vector<Case> cases = {
        {"a face of 0 vertices (every face dropped)", "OFF\n3 1 0\n" + vertices + "0 0 0 0\n",
         ":6: face 1 has 0 vertices; faces of 1 to 9 vertices can be read (split larger ones)"},
        {"a face of 10 vertices", "OFF\n3 1 0\n" + vertices + "10 0 1 2 0 1 2 0 1 2 0\n",
         ":6: face 1 has 10 vertices; faces of 1 to 9 vertices can be read (split larger ones)"},
        {"an index that is not a number", "OFF\n3 1 0\n" + vertices + "3 0 1 2x\n",
         ":6: face 1: vertex index '2x' is not one of 0 to 2"},
        {"too few indices", "OFF\n3 1 0\n" + vertices + "3 0 1\n# x\n",
         ":6: face 1 has 2 of its 3 vertex indices"},
        {"a comment line among the vertices", "OFF\n3 1 0\n0 0 0\n# x\n1 0 0\n0 1 0\n3 0 1 2\n",
         ":4: a blank or comment line where vertex 2 of 3 should be (it would be read as one)"},
        {"a coordinate that is not a number", "OFF\n3 1 0\n0 0 0\n1 O 0\n0 1 0\n3 0 1 2\n",
         ":4: vertex 2: 'O' is not a number"},
        {"a vertex of two coordinates", "OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
         ":4: vertex 2 has 2 of its 3 coordinates"},
        {"no edges' count", "OFF\n3 1\n" + vertices + "3 0 1 2\n",
         ":2: the header has no count of edges after those of vertices and faces (write 0): "
         "without it the first vertex is misread"},
        {"no keyword", "3 1 0\n" + vertices + "3 0 1 2\n",
         ":1: no OFF keyword before the counts (OFF, COFF, NOFF, STOFF, 4OFF or nOFF): without "
         "one the header is misread"},
        {"a line of 5,000 bytes",
         "OFF\n3 1 0\n0 0 0" + std::string(5000, ' ') + "\n1 0 0\n0 1 0\n3 0 1 2\n",
         ":3: a line of 5005 bytes; lines of vertices and faces must be shorter than 4,095 bytes"},
        {"a NUL byte", std::string("OFF\n3 1 0\n0 0 0\n1 0\0 0\n0 1 0\n3 0 1 2\n", 31),
         ":4: a NUL byte: an OFF file is text"},
        {"the file ends early", "OFF\n3 1 0 " + vertices,
         ":2: the header declares 3 vertices and 1 faces, but only 3 lines of data follow"},
        {"four dimensions", "nOFF 4\n3 1 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n",
         ":2: the vertices have 4 coordinates; 1 to 3 can be read"},
    };
    for (const Case& c : cases) {
        CAPTURE(c.what);
        write_text(dir.file("bad.off"), c.text);
        CHECK(input_error([&] { load_scene(dir.file("bad.off")); }) ==
              dir.file("bad.off") + c.message);
    }
    // What the format allows is read: comments and blank lines in the header, the counts on the
    // keyword's line, a comment after a face, blank lines between the lines of data, CR LF, a
    // homogeneous coordinate, 2-D vertices.
    const std::vector<std::string> good = {
        "OFF\n# made by hand\n\n3 1 0\n" + vertices + "3 0 1 2 # the face\n",
        "OFF 3 1 0\n" + vertices + "\n\n3 0 1 2\n",
        "OFF\r\n3 1 0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 2\r\n",
        "4OFF\n3 1 0\n0 0 0 2\n2 0 0 2\n0 2 0 2\n3 0 1 2\n",
        "nOFF 2\n3 1 0\n0 0\n1 0\n0 1\n3 0 1 2\n",
    };
    for (const std::string& text : good) {
        CAPTURE(text);
        write_text(dir.file("good.off"), text);
        const Scene s = load_scene(dir.file("good.off"));
        REQUIRE(s.surfaces.size() == 1);
        CHECK(area(s.surfaces[0].polygon) == doctest::Approx(0.5));
    }
}

TEST_CASE("mesh: bad meshes are input errors naming the file, mesh and face") {
    const TempDir dir;
    TestMesh tris = triangulated(unit_box_quads("box"));
    // A degenerate triangle (two corners at one point).
    TestMesh flat = tris;
    flat.faces[4] = {0, 1, 1};
    write_text(dir.file("flat.stl"), stl_binary(flat));
    CHECK(input_error([&] {
              load_scene(dir.file("flat.stl"));
          }).find("flat.stl: mesh 'flat' face 5 has a zero-length edge") != std::string::npos);
    // A NaN coordinate.
    TestMesh bad = tris;
    bad.vertices[6].y() = std::numeric_limits<double>::quiet_NaN();
    write_text(dir.file("nan.stl"), stl_binary(bad));
    CHECK(input_error([&] { load_scene(dir.file("nan.stl")); }).find("nan.stl: mesh 'nan' face") !=
          std::string::npos);
    CHECK(input_error([&] {
              load_scene(dir.file("nan.stl"));
          }).find("has a coordinate that is not finite") != std::string::npos);
    // Not a mesh at all, and a missing file.
    write_text(dir.file("junk.stl"), "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n");
    CHECK(input_error([&] {
              load_scene(dir.file("junk.stl"));
          }).rfind(dir.file("junk.stl") + ": cannot read the mesh (Open Asset Import: ", 0) == 0);
    // Under an extension two of its readers claim, content neither recognises (here a PLY
    // header without end_header, which its PLY reader, tried next, would loop on forever).
    write_text(dir.file("junk.gltf"), "ply\nformat ascii 1.0\nelement vertex 8\n");
    CHECK(input_error([&] { load_scene(dir.file("junk.gltf")); }) ==
          dir.file("junk.gltf") +
              ": not a .gltf file that Open Asset Import recognises (damaged, or another format "
              "under this extension?)");
    write_text(dir.file("junk.ply"), "ply\nformat nonsense\n");
    CHECK(input_error([&] { load_scene(dir.file("junk.ply")); }) ==
          dir.file("junk.ply") +
              ":2: expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian)");
    CHECK(input_error([&] { load_scene(dir.file("missing.glb")); }) ==
          dir.file("missing.glb") + ": cannot open file");
    // A face that indexes past the vertices.
    write_text(dir.file("index.off"), "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    CHECK(input_error([&] { load_scene(dir.file("index.off")); }) ==
          dir.file("index.off") + ":6: face 1: vertex index '7' is not one of 0 to 2");
    // Counts that the file cannot hold are refused before anything is allocated for them.
    write_text(dir.file("counts.off"), "OFF\n# a comment\n3 155555555558\n0 0 0\n1 0 0\n");
    CHECK(input_error([&] { load_scene(dir.file("counts.off")); }) ==
          dir.file("counts.off") +
              ":3: the count of faces '155555555558' is not a whole number below 2^31");
    write_text(dir.file("short.off"), "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    CHECK(input_error([&] { load_scene(dir.file("short.off")); }) ==
          dir.file("short.off") +
              ":2: the header declares 3 vertices and 2 faces, but only 4 lines of data follow");
    write_text(dir.file("nocounts.off"), "OFF\n");
    CHECK(input_error([&] { load_scene(dir.file("nocounts.off")); }) ==
          dir.file("nocounts.off") +
              ": not an OFF file: no counts of vertices and faces in its header");
    // Binary glTF whose header declares more than the file holds: version 1 with a scene of
    // 1.85 GB in 33 bytes (Open Asset Import allocated it), version 2 with a chunk past the end.
    const std::string v1 = std::string("glTF\x01\0\0\0\0\0\0\0\0scn", 16) + std::string(17, '\0');
    write_text(dir.file("scene.glb"), v1);
    CHECK(
        input_error([&] { load_scene(dir.file("scene.glb")); }) ==
        dir.file("scene.glb") +
            ": binary glTF: the header declares a scene of 1852011264 bytes, but the file has 33");
    std::string v2("glTF\x02\0\0\0\x20\0\0\0\x40\0\0\0JSON", 20);
    v2 += std::string(12, ' ');
    write_text(dir.file("chunk.glb"), v2);
    CHECK(input_error([&] { load_scene(dir.file("chunk.glb")); }) ==
          dir.file("chunk.glb") +
              ": binary glTF: the header declares a chunk of 64 bytes, but the file has 32");
}

TEST_CASE("mesh: the CLI computes on an STL and refuses a broken one with one message") {
    Cli cli;
    write_text(cli.file("box.stl"), stl_ascii(triangulated(unit_box_quads("box"))));
    CliResult r = cli.run("compute box.stl -o F.csv --method analytic");
    INFO(r.out << r.err);
    CHECK(r.code == 0);
    TestMesh flat = triangulated(unit_box_quads("box"));
    flat.faces[0] = {0, 0, 1};
    write_text(cli.file("flat.stl"), stl_binary(flat));
    r = cli.run("compute flat.stl -o G.csv");
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK_FALSE(std::filesystem::exists(cli.file("G.csv")));
}
