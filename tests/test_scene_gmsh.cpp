// Gmsh meshes (.msh): files that Debian's `gmsh` writes here and now (versions 2.2 and 4.1, text
// and binary, with physical groups), small hand-written files, and the error contract.

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/mesh_io.h"
#include "support/cli_runner.h"
#include "support/files.h"
#include "support/matrix_checks.h"
#include "support/scenes.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::input_error;
using formfactor::testing::shell_quote;
using formfactor::testing::TempDir;
using formfactor::testing::write_text;

namespace {

// The closed unit box, every face's curve loop oriented so that its normal points inward; the
// walls are recombined into quads. `flip_west`: the x = 0 wall's loop reversed (it then faces
// out of the box).
std::string box_geo(bool flip_west = false) {
    std::string g = R"(SetFactory("Built-in");
lc = 0.6;
Point(1) = {0,0,0,lc}; Point(2) = {1,0,0,lc}; Point(3) = {1,1,0,lc}; Point(4) = {0,1,0,lc};
Point(5) = {0,0,1,lc}; Point(6) = {1,0,1,lc}; Point(7) = {1,1,1,lc}; Point(8) = {0,1,1,lc};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Line(5) = {5,6}; Line(6) = {6,7}; Line(7) = {7,8}; Line(8) = {8,5};
Line(9) = {1,5}; Line(10) = {2,6}; Line(11) = {3,7}; Line(12) = {4,8};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Curve Loop(2) = {5,6,7,8}; Plane Surface(2) = {-2};
Curve Loop(3) = {9,5,-10,-1}; Plane Surface(3) = {3};
Curve Loop(4) = {10,6,-11,-2}; Plane Surface(4) = {4};
Curve Loop(5) = {11,7,-12,-3}; Plane Surface(5) = {5};
Curve Loop(6) = {12,8,-9,-4}; Plane Surface(6) = {)";
    g += flip_west ? "-6" : "6";
    g += R"(};
Recombine Surface{3,4,5,6};
Physical Surface("floor") = {1};
Physical Surface("ceiling") = {2};
Physical Surface("walls") = {3,4,5,6};
)";
    return g;
}

// Runs gmsh on `geo` (a file in dir) to write `out` in `format` (msh22 / msh41), binary or not.
void run_gmsh(const TempDir& dir, const std::string& geo, const std::string& out,
              const std::string& format, bool binary) {
    const std::string cmd = "gmsh -2 -format " + format + (binary ? " -bin" : "") + " -o " +
                            shell_quote(dir.file(out)) + " " + shell_quote(dir.file(geo)) + " > " +
                            shell_quote(dir.file(out + ".log")) + " 2>&1";
    INFO("command: " << cmd);
    REQUIRE_MESSAGE(std::system(cmd.c_str()) == 0,
                    "gmsh failed or is missing (Debian package gmsh, in the Makefile's "
                    "DEB_PACKAGES)");
}

struct GmshBox {
    TempDir dir;
    std::vector<std::string> files;  // 2.2 text, 2.2 binary, 4.1 text, 4.1 binary
    explicit GmshBox(bool flip_west = false) {
        write_text(dir.file("box.geo"), box_geo(flip_west));
        for (const char* format : {"msh22", "msh41"})
            for (bool binary : {false, true}) {
                const std::string out =
                    std::string("box-") + format + (binary ? "-bin" : "-txt") + ".msh";
                run_gmsh(dir, "box.geo", out, format, binary);
                files.push_back(dir.file(out));
            }
    }
};

// F between two unit faces of the built-in cube (computed, analytic): opposite and adjacent.
std::pair<double, double> cube_factors() {
    const Scene cube = builtin_scene("cube");
    const ComputeResult r = compute_form_factors(cube);
    double opposite = 0, adjacent = 0;
    for (std::size_t j = 1; j < cube.patches.size(); ++j) {
        const double d = cube.patches[0].normal.dot(cube.patches[j].normal);
        (d < -0.5 ? opposite : adjacent) = r.form_factors.F(0, static_cast<Eigen::Index>(j));
    }
    return {opposite, adjacent};
}

}  // namespace

TEST_CASE("gmsh: the box gmsh writes reads the same in 2.2 and 4.1, text and binary") {
    const GmshBox box;
    const Scene first = load_msh(box.files[0]);
    REQUIRE(first.surfaces.size() > 12);
    for (const std::string& f : box.files) {
        INFO(f);
        const Scene s = load_scene(f);
        REQUIRE(s.surfaces.size() == first.surfaces.size());
        for (std::size_t k = 0; k < s.surfaces.size(); ++k) {
            CHECK(s.surfaces[k].name == first.surfaces[k].name);
            CHECK(s.surfaces[k].combine == first.surfaces[k].combine);
            // Text files hold 16 significant digits, binary ones every bit.
            CHECK(testing::same_cycle(s.surfaces[k].polygon, first.surfaces[k].polygon, 1e-14));
        }
        // Every element faces into the box (the curve loops say so, and the node order keeps it).
        double area = 0.0;
        for (const Patch& p : s.patches) {
            CHECK(p.normal.dot(Vec3(0.5, 0.5, 0.5) - p.centroid) > 0.0);
            area += p.area;
        }
        CHECK(std::abs(area - 6.0) < 1e-12);
        std::size_t quads = 0;
        for (const Surface& x : s.surfaces) quads += x.polygon.size() == 4 ? 1 : 0;
        CHECK(quads > 0);  // the recombined walls
        const PatchGroups g = surface_groups(s);
        CHECK(g.names == std::vector<std::string>{"floor", "ceiling", "walls"});
    }
}

TEST_CASE("gmsh: per-surface form factors of the meshed box are the cube's (analytic)") {
    const GmshBox box;
    const auto [opposite, adjacent] = cube_factors();
    // Rows floor, ceiling, walls; A_walls = 4. Each wall sees two adjacent walls and one
    // opposite one: F_walls,walls = opposite + 2 adjacent.
    const double expected[3][3] = {{0, opposite, 4 * adjacent},
                                   {opposite, 0, 4 * adjacent},
                                   {adjacent, adjacent, opposite + 2 * adjacent}};
    for (const std::string& f : {box.files[0], box.files[3]}) {
        INFO(f);
        const Scene s = load_scene(f);
        const FormFactors F = aggregate_per_surface(s, compute_form_factors(s).form_factors);
        REQUIRE(F.F.rows() == 3);
        // Per-entry error target 1e-10 (analytic), summed over at most ~100² pairs.
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) CHECK(std::abs(F.F(i, j) - expected[i][j]) < 1e-7);
    }
}

TEST_CASE("gmsh: the meshed box with --merge-coplanar gives the cube's matrix to 1e-12") {
    // Merged, each face of the mesh is the unit cube's face (its edge nodes dropped as
    // collinear), so every entry is the cube's, whatever order the faces come in. Also as the
    // STL that gmsh writes (a tool other than ours; its quads split into triangles).
    const GmshBox box;
    std::vector<std::string> files = box.files;
    for (bool binary : {false, true}) {
        const std::string out = binary ? "box-bin.stl" : "box-txt.stl";
        run_gmsh(box.dir, "box.geo", out, "stl", binary);
        files.push_back(box.dir.file(out));
    }
    const Scene cube = testing::unit_cube(1);
    const DenseMatrix F0 = compute_form_factors(cube).form_factors.F;
    for (const std::string& f : files) {
        INFO(f);
        SceneOptions o;
        o.source = f;
        o.merge_coplanar = true;
        const Scene s = prepare_scene(o);
        REQUIRE(s.surfaces.size() == 6);
        testing::check_same_matrix_up_to_order(s, compute_form_factors(s).form_factors.F, cube, F0,
                                               1e-12);
    }
}

TEST_CASE("gmsh: a closed mesh with one wall facing out is an error naming an element") {
    const GmshBox box(true);
    for (const std::string& f : box.files) {
        INFO(f);
        const std::string e = input_error([&] { load_scene(f); });
        CHECK(e.rfind(f + ":", 0) == 0);
        CHECK(e.find("(in 'walls') faces the other way from its neighbours on a closed surface") !=
              std::string::npos);
    }
    // The text files name the element's line.
    const std::string e = input_error([&] { load_scene(box.files[0]); });
    CHECK(e.find(".msh:") != std::string::npos);
    CHECK(std::isdigit(static_cast<unsigned char>(e[box.files[0].size() + 1])));
}

TEST_CASE("gmsh: the CLI writes one row per physical group with --per-surface") {
    const GmshBox box;
    formfactor::testing::Cli cli;
    const auto r = cli.run("compute " + shell_quote(box.files[1]) +
                           " --per-surface -o F.csv --method analytic");
    INFO(r.out << r.err);
    REQUIRE(r.code == 0);
    const std::string csv = formfactor::testing::read_text(cli.file("F.csv"));
    std::size_t lines = 0;
    for (char c : csv) lines += c == '\n' ? 1 : 0;
    CHECK(lines >= 3);
    CHECK(lines <= 4);  // three rows, perhaps a header
}

TEST_CASE("gmsh: hand-written 2.2 and 4.1 files: quads, names, obstruction groups") {
    // Two unit squares facing each other one apart, and a post that only blocks.
    const Scene a = load_msh(data("gmsh/plates-2.2.msh"));
    const Scene b = load_msh(data("gmsh/plates-4.1.msh"));
    for (const Scene* s : {&a, &b}) {
        REQUIRE(s->surfaces.size() == 3);
        CHECK(s->surfaces[0].name == "bottom");
        CHECK(s->surfaces[1].name == "top");
        CHECK(s->surfaces[2].name == "Obstruction-post");
        CHECK(s->surfaces[2].obstruction);
        CHECK(s->obstruction_count() == 1);
        REQUIRE(s->patches.size() == 2);
        CHECK(s->patches[0].normal.z() == doctest::Approx(1.0));
        CHECK(s->patches[1].normal.z() == doctest::Approx(-1.0));
        for (std::size_t k = 0; k < 3; ++k)
            CHECK(testing::same_cycle(a.surfaces[k].polygon, b.surfaces[k].polygon, 0.0));
    }
    CHECK(a.surfaces[0].where.line == 27);
}

TEST_CASE("gmsh: error messages name file, line or element, and what is wrong") {
    auto err = [](const std::string& name, const std::string& text) {
        const std::string path = testing::write_file(name, text);
        return input_error([&] { load_msh(path); });
    };
    const std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
    const std::string nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 1 1 0\n4 0 1 0\n$EndNodes\n";
    CHECK(err("missing-node.msh", head + nodes + "$Elements\n1\n7 2 2 1 1 1 2 9\n$EndElements\n")
              .find("missing-node.msh:13: element 7 refers to node 9, which the file does not "
                    "define") != std::string::npos);
    CHECK(err("v40.msh", "$MeshFormat\n4 0 8\n$EndMeshFormat\n")
              .find("v40.msh:2: MSH version 4 is not supported") != std::string::npos);
    CHECK(err("notmsh.msh", "solid x\n").find("notmsh.msh:1: not a Gmsh mesh") !=
          std::string::npos);
    CHECK(err("curved.msh", head + nodes + "$Elements\n1\n3 9 2 1 1 1 2 3 4 1 2\n$EndElements\n")
              .find("curved.msh:13: element 3 is a curved (type 9") != std::string::npos);
    CHECK(err("twice.msh",
              head + nodes + "$Elements\n2\n1 2 2 1 1 1 2 3\n2 2 2 2 1 1 2 3\n$EndElements\n")
              .find("twice.msh:14: element 2 (in 'physical-2') has the same nodes as element 1 "
                    "(in 'physical-1')") != std::string::npos);
    CHECK(err("flat.msh", head + nodes + "$Elements\n1\n1 2 2 1 1 1 2 2\n$EndElements\n")
              .find("flat.msh:13: element 1 has a zero-length edge") != std::string::npos);
    CHECK(err("bent.msh", head + "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 1 1 0.5\n4 0 1 0\n$EndNodes\n"
                                 "$Elements\n1\n1 3 2 1 1 1 2 3 4\n$EndElements\n")
              .find("bent.msh:13: element 1 is not planar") != std::string::npos);
    CHECK(err("noend.msh", head + "$Nodes\n1\n1 0 0 0\n$Elements\n")
              .find("noend.msh:7: expected $EndNodes, found '$Elements'") != std::string::npos);
    CHECK(err("nan.msh", head + "$Nodes\n1\n1 0 nan 0\n$EndNodes\n")
              .find("nan.msh:6: a node coordinate 'nan' is not finite") != std::string::npos);
    CHECK(err("lines.msh", head + nodes + "$Elements\n1\n1 1 2 1 1 1 2\n$EndElements\n")
              .find("lines.msh: the scene is empty: no triangles or quads") != std::string::npos);
    CHECK(err("huge.msh", head + "$Nodes\n1000000000\n1 0 0 0\n$EndNodes\n")
              .find("huge.msh:5: the file claims 1000000000 nodes, more than it can hold") !=
          std::string::npos);
    // A closed tetrahedron with one face turned.
    const std::string tetra = data("gmsh/tetra-one-face-turned.msh");
    CHECK(input_error([&] { load_msh(tetra); }) ==
          tetra +
              ":20: element 4 (in 'shell') faces the other way from its neighbours on a closed "
              "surface (1 of its 4 elements do): the node order gives the front, "
              "counter-clockwise seen from the front");
}

TEST_CASE("gmsh: a cut-off binary file is an error naming the byte") {
    const GmshBox box;
    for (const std::string& f : {box.files[1], box.files[3]}) {
        const std::string bytes = formfactor::testing::read_text(f);
        const std::string cut = f + ".cut.msh";
        write_text(cut, bytes.substr(0, bytes.size() * 2 / 3));
        const std::string e = input_error([&] { load_msh(cut); });
        INFO(e);
        CHECK(e.rfind(cut + ": byte ", 0) == 0);
    }
}
