// merge_coplanar(): triangles of one surface group merged back into the planar polygons they
// were cut from (a CAD box in STL is 6 faces), with holes, keeping the area.

#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "formfactor/matrix/aggregate.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/merge_coplanar.h"
#include "formfactor/scene/mesh_io.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/files.h"
#include "support/mesh_files.h"
#include "support/temp_dir.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

double total_area(const Scene& s) {
    double a = 0;
    for (const Surface& x : s.surfaces) a += surface_area(x);
    return a;
}

}  // namespace

TEST_CASE("merge coplanar: the box as STL (ASCII, binary) merges into the OBJ's 6 faces") {
    const TempDir dir;
    const TestMesh quads = unit_box_quads("box");
    write_text(dir.file("box.obj"), obj({quads}));
    write_text(dir.file("box-ascii.stl"), stl_ascii(triangulated(quads)));
    write_text(dir.file("box-binary.stl"), stl_binary(triangulated(quads)));
    SceneOptions o;
    o.source = dir.file("box.obj");
    o.merge_coplanar = true;  // OBJ faces are surfaces of their own: nothing to merge
    const Scene reference = prepare_scene(o);
    REQUIRE(reference.surfaces.size() == 6);
    const DenseMatrix F0 = compute_form_factors(reference).form_factors.F;
    for (const char* name : {"box-ascii.stl", "box-binary.stl"}) {
        INFO(name);
        o.source = dir.file(name);
        o.merge_coplanar = false;
        CHECK(prepare_scene(o).surfaces.size() == 12);
        o.merge_coplanar = true;
        const Scene s = prepare_scene(o);
        REQUIRE(s.surfaces.size() == 6);  // a CAD box is 6 surfaces
        for (std::size_t k = 0; k < 6; ++k) {
            CHECK(testing::same_cycle(s.surfaces[k].polygon, reference.surfaces[k].polygon, 0.0));
            CHECK(s.surfaces[k].combine == (k == 0 ? -1 : 0));  // still one mesh, one group
        }
        const DenseMatrix F = compute_form_factors(s).form_factors.F;
        CHECK((F - F0).cwiseAbs().maxCoeff() <= 1e-12);
        // The per-surface rows: the mesh is one group whose row closes.
        const FormFactors G = aggregate_per_surface(s, compute_form_factors(s).form_factors);
        CHECK(std::abs(G.F(0, 0) - 1.0) < 1e-9);
    }
}

TEST_CASE("merge coplanar: a triangulated wall with a window becomes one polygon with a hole") {
    // A 4 x 3 wall (z = 0, facing +z) with a 1 x 1 window cut out, as 8 triangles around it
    // (the ring between the outer square and the window, fanned corner by corner).
    TestMesh m;
    m.name = "wall";
    m.vertices = {{0, 0, 0}, {4, 0, 0}, {4, 3, 0}, {0, 3, 0},
                  {1, 1, 0}, {2, 1, 0}, {2, 2, 0}, {1, 2, 0}};
    // Outer k → k+1 with inner k → k+1: quads (o_k, o_k+1, i_k+1, i_k) into two triangles.
    for (int k = 0; k < 4; ++k) {
        const int o0 = k, o1 = (k + 1) % 4, i0 = 4 + k, i1 = 4 + (k + 1) % 4;
        m.faces.push_back({o0, o1, i1});
        m.faces.push_back({o0, i1, i0});
    }
    const TempDir dir;
    write_text(dir.file("wall.stl"), stl_ascii(m));
    Scene s = load_scene(dir.file("wall.stl"));
    const double before = total_area(s);
    REQUIRE(s.surfaces.size() == 8);
    const MergeReport r = merge_coplanar(s);
    CHECK(r.faces_before == 8);
    CHECK(r.faces_after == 1);
    CHECK(r.regions_kept == 0);
    REQUIRE(s.surfaces.size() == 1);
    CHECK(s.surfaces[0].polygon.size() == 4);
    REQUIRE(s.surfaces[0].holes.size() == 1);
    CHECK(s.surfaces[0].holes[0].size() == 4);
    CHECK(normal(s.surfaces[0].holes[0]).dot(normal(s.surfaces[0].polygon)) > 0.999);
    CHECK(std::abs(total_area(s) - 11.0) <= 1e-12 * 11.0);
    CHECK(std::abs(total_area(s) - before) <= 1e-12 * before);
    CHECK(std::abs(s.total_patch_area() - 11.0) <= 1e-12 * 11.0);
}

TEST_CASE("merge coplanar: a bent region stays apart, each Gmsh group merges on its own") {
    // Two triangles sharing an edge, one tilted by 1e-3: not coplanar (tolerance 1e-6).
    TestMesh m;
    m.name = "bent";
    m.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 1e-3}, {0, 1, 0}};
    m.faces = {{0, 1, 3}, {1, 2, 3}};
    const TempDir dir;
    write_text(dir.file("bent.stl"), stl_ascii(m));
    Scene s = load_scene(dir.file("bent.stl"));
    merge_coplanar(s);
    CHECK(s.surfaces.size() == 2);
    // Within the tolerance (1e-8 of the size): merged.
    m.vertices[2].z() = 1e-8;
    write_text(dir.file("flat.stl"), stl_ascii(m));
    s = load_scene(dir.file("flat.stl"));
    merge_coplanar(s);
    CHECK(s.surfaces.size() == 1);

    // Gmsh: each physical group merges on its own (the plates of tests/data are single quads).
    Scene g = load_msh(testing::data("gmsh/plates-4.1.msh"));
    const std::size_t n = g.surfaces.size();
    merge_coplanar(g);
    CHECK(g.surfaces.size() == n);
    CHECK(g.obstruction_count() == 1);
}

TEST_CASE("merge coplanar: the CLI's --merge-coplanar gives the OBJ box's matrix") {
    Cli cli;
    const TestMesh quads = unit_box_quads("box");
    write_text(cli.file("box.obj"), obj({quads}));
    write_text(cli.file("box.stl"), stl_binary(triangulated(quads)));
    CliResult r = cli.run("compute box.obj -o A.csv --method analytic");
    REQUIRE(r.code == 0);
    r = cli.run("compute box.stl --merge-coplanar -o B.csv --method analytic");
    INFO(r.out << r.err);
    REQUIRE(r.code == 0);
    const DenseMatrix a = read_matrix(cli.file("A.csv")), b = read_matrix(cli.file("B.csv"));
    REQUIRE(a.rows() == 6);
    REQUIRE(b.rows() == 6);
    CHECK((a - b).cwiseAbs().maxCoeff() <= 1e-12);
    r = cli.run("info box.stl --merge-coplanar");
    CHECK(r.out.find("--merge-coplanar: 12 faces merged into 6 surfaces") != std::string::npos);
}
