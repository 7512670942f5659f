// Surfaces with holes: VS3 subsurfaces cut out of their base, subdivision of what is left.

#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "support/files.h"

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::input_error;
using formfactor::testing::write_file;

namespace {

std::vector<double> patch_area_by_surface(const Scene& s) {
    std::vector<double> a(s.surfaces.size(), 0.0);
    for (const Patch& p : s.patches) a[static_cast<std::size_t>(p.surface)] += p.area;
    return a;
}

// Expected areas of room-windows.vs3 (surface minus its direct subsurfaces).
const std::vector<double> kRoomAreas{12.0,                    // floor
                                     12.0,                    // ceiling
                                     10.0 - 1.5 * 1.2,        // south minus window
                                     10.0 - 1.0 - 1.0 - 1.0,  // north minus three windows
                                     7.5 - 2.0,               // west minus door
                                     7.5,                     // east
                                     1.5 * 1.2 - 1.1 * 0.8,   // window minus pane
                                     1.1 * 0.8,               // pane
                                     2.0,                     // door
                                     1.0,
                                     1.0,
                                     1.0};  // north-a, north-b, north-corner

std::string vs3_error(const std::string& name, const std::string& text) {
    const std::string p = write_file(name, text);
    const std::string m = input_error([&] { load_scene(p); });
    const std::string dir = formfactor::testing::scratch_dir().string() + "/";
    return m.rfind(dir, 0) == 0 ? m.substr(dir.size()) : m;
}

// A 2 × 1 wall in z = 0 facing +z (vertices 1-4) and spare vertices 5.. for subsurfaces.
const std::string kWall =
    "F 3\nV 1 0 0 0\nV 2 2 0 0\nV 3 2 1 0\nV 4 0 1 0\n"
    "V 5 0.2 0.2 0\nV 6 0.8 0.2 0\nV 7 0.8 0.8 0\nV 8 0.2 0.8 0\n"
    "V 9 0.5 0.5 0\nV 10 1.1 0.5 0\nV 11 1.1 0.9 0\nV 12 0.5 0.9 0\n"
    "S 1 1 2 3 4 0 0 0.9 wall\n";  // lines 1-14

}  // namespace

TEST_CASE("scene: VS3 subsurfaces are cut out of their base, areas add up exactly") {
    const Scene s = load_scene(data("room-windows.vs3"));
    REQUIRE(s.surfaces.size() == 12);
    CHECK(s.warnings.empty());
    CHECK(s.enclosure);
    CHECK(s.surfaces[2].holes.size() == 1);  // south: the window
    CHECK(s.surfaces[3].holes.size() == 3);  // north: three windows
    CHECK(s.surfaces[4].holes.size() == 1);  // west: the door
    CHECK(s.surfaces[6].holes.size() == 1);  // window: the pane (a sub-subsurface)
    CHECK(s.surfaces[7].base == 6);
    CHECK(s.surfaces[0].holes.empty());
    // Whatever the subdivision, the patches of a surface cover exactly surface minus holes.
    for (const SubdivisionOptions o :
         {SubdivisionOptions{1, 0.0}, SubdivisionOptions{4, 0.0}, SubdivisionOptions{1, 0.3}}) {
        Scene t = s;
        subdivide(t, o);
        const std::vector<double> a = patch_area_by_surface(t);
        double total = 0.0;
        for (std::size_t k = 0; k < 12; ++k) {
            CHECK_MESSAGE(std::abs(a[k] - kRoomAreas[k]) <= 1e-12 * kRoomAreas[k], "surface ",
                          k + 1, " n ", o.n, " L ", o.max_edge);
            CHECK(std::abs(surface_area(t.surfaces[k]) - kRoomAreas[k]) <= 1e-12 * kRoomAreas[k]);
            total += kRoomAreas[k];
        }
        // The closed room's walls are covered once: 2·12 + 2·10 + 2·7.5.
        CHECK(std::abs(t.total_patch_area() - 59.0) <= 1e-12 * 59.0);
        CHECK(std::abs(total - 59.0) <= 1e-12 * 59.0);
        // Patches face like their surface, are valid polygons, and stay out of the holes.
        for (const Patch& p : t.patches) {
            const Surface& x = t.surfaces[static_cast<std::size_t>(p.surface)];
            CHECK((p.normal - normal(x.polygon)).norm() < 1e-12);
            CHECK(is_simple(p.polygon));
            for (const Polygon& h : x.holes) CHECK(overlap_area(p.polygon, h) <= 1e-14);
        }
        if (o.max_edge > 0)
            for (const Patch& p : t.patches) CHECK(max_edge_length(p.polygon) <= 0.3 * (1 + 1e-12));
    }
    // n = 1: a wall with a window in the middle is 4 convex pieces, the west wall with its door
    // on the floor edge 3, the window with its pane 4.
    std::vector<int> count(12, 0);
    for (const Patch& p : s.patches) ++count[static_cast<std::size_t>(p.surface)];
    CHECK(count[0] == 1);
    CHECK(count[2] == 4);
    CHECK(count[4] == 3);
    CHECK(count[6] == 4);
    CHECK(count[7] == 1);
}

TEST_CASE("scene: a door on the floor edge and a window in a corner (View3D-style F 3a)") {
    // F 3a rectangles: origin, azimuth 180, tilt 90 (a wall in y = 0), width, height.
    const std::string text =
        "F 3a\n"
        "S 1 R 0 0 0.9 wall\n 0 0 0  180 90  4 2.5\n"
        "S 2 R 1 0 0.9 door\n 1 0 0  180 90  1 2\n"
        "S 3 R 1 0 0.9 corner\n 3 0 1.5  180 90  1 1\n"
        "E\n";
    const Scene s = load_scene(write_file("door.vs3", text));
    REQUIRE(s.surfaces[0].holes.size() == 2);
    CHECK(std::abs(normal(s.surfaces[0].polygon).y()) == 1.0);
    const std::vector<double> a = patch_area_by_surface(s);
    CHECK(std::abs(a[0] - (10.0 - 2.0 - 1.0)) <= 1e-12 * 10.0);
    CHECK(a[1] == doctest::Approx(2.0).epsilon(1e-15));
    CHECK(a[2] == doctest::Approx(1.0).epsilon(1e-15));
}

TEST_CASE("scene: VS3 subsurface errors") {
    // Overlapping siblings.
    CHECK(vs3_error("ov.vs3", kWall + "S 2 5 6 7 8 1 0 0.9 a\nS 3 9 10 11 12 1 0 0.9 b\n") ==
          "ov.vs3:16: surface 3 overlaps surface 2 (both subsurfaces of surface 1; overlap area "
          "0.09): subsurfaces of one base must not overlap");
    // Touching siblings are fine; so is a subsurface of a subsurface.
    CHECK(vs3_error("ok.vs3", kWall + "V 13 1.4 0.2 0\nV 14 1.4 0.8 0\n" +
                                  "S 2 5 6 7 8 1 0 0.9 a\nS 3 6 13 14 7 1 0 0.9 b\n") == "");
    CHECK(vs3_error("nest.vs3", kWall + "V 13 0.3 0.3 0\nV 14 0.6 0.3 0\nV 15 0.6 0.6 0\n" +
                                    "S 2 5 6 7 8 1 0 0.9 a\nS 3 13 14 15 0 2 0 0.9 b\n") == "");
    // A subsurface whose corners are all in a non-convex base (a dart, reflex at (2, 1)) while
    // an edge crosses its notch.
    CHECK(vs3_error("notch.vs3",
                    "F 3\nV 1 0 0 0\nV 2 4 0 0\nV 3 2 1 0\nV 4 2 4 0\nV 5 3 0.2 0\nV 6 1.9 3 0\n"
                    "V 7 1 0.3 0\nS 1 1 2 3 4 0 0 0.9 a\nS 2 5 6 7 0 1 0 0.9 b\n")
              .rfind("notch.vs3:10: surface 2 is not entirely within its base surface 1 (area ",
                     0) == 0);
}

TEST_CASE("scene: writers keep holes (VS3 as subsurfaces, OBJ as pieces)") {
    const Scene a = load_scene(data("room-windows.vs3"));
    const std::string vs3 = (formfactor::testing::scratch_dir() / "holes.vs3").string();
    save_vs3(a, vs3);
    const Scene b = load_scene(vs3);
    REQUIRE(b.surfaces.size() == a.surfaces.size());
    for (std::size_t k = 0; k < a.surfaces.size(); ++k) {
        CHECK(b.surfaces[k].base == a.surfaces[k].base);
        CHECK(b.surfaces[k].holes.size() == a.surfaces[k].holes.size());
    }
    CHECK(std::abs(b.total_patch_area() - 59.0) <= 1e-12 * 59.0);

    const std::string obj = (formfactor::testing::scratch_dir() / "holes.obj").string();
    save_obj(a, obj);
    const Scene c = load_scene(obj);
    CHECK(c.surfaces.size() > a.surfaces.size());  // walls with holes come back in pieces
    CHECK(std::abs(c.total_patch_area() - 59.0) <= 1e-12 * 59.0);

    // Holes that are not subsurfaces cannot be written to VS3.
    Scene d = a;
    d.surfaces[0].holes.push_back(Polygon{{Vec3(1, 1, 0), Vec3(2, 1, 0), Vec3(2, 2, 0)}});
    CHECK_THROWS_AS(save_vs3(d, vs3), GeometryError);
}

TEST_CASE("scene: holes on a hand-built surface") {
    Scene s;
    s.materials.push_back(Material{});
    Surface x;
    x.name = "wall";
    x.polygon = Polygon{{Vec3(0, 0, 0), Vec3(4, 0, 0), Vec3(4, 2, 0), Vec3(0, 2, 0)}};
    x.holes.push_back(
        Polygon{{Vec3(1, 0.5, 0), Vec3(2, 0.5, 0), Vec3(2, 1.5, 0), Vec3(1, 1.5, 0)}});
    x.holes.push_back(Polygon{{Vec3(3, 0, 0), Vec3(4, 0, 0), Vec3(3.5, 1, 0)}});  // on the edge
    s.surfaces.push_back(x);
    CHECK(surface_area(s.surfaces[0]) == doctest::Approx(8.0 - 1.0 - 0.5).epsilon(1e-15));
    for (int n : {1, 2, 5}) {
        subdivide(s, {n, 0.0});
        CHECK(std::abs(s.total_patch_area() - 6.5) <= 1e-12 * 6.5);
        for (const Patch& p : s.patches) CHECK(p.surface == 0);
    }
}
