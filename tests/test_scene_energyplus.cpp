// EnergyPlus models read as one zone each: EnergyPlus's own example zone (tests/data/energyplus,
// see its README), its epJSON twin, and the conventions (vertex direction, relative coordinates,
// zones) and error paths of the reader.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "formfactor/matrix/aggregate.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/energyplus.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "support/files.h"
#include "support/matrix_checks.h"
#include "support/method_runner.h"

using namespace formfactor;
using formfactor::testing::check_enclosure_rows;
using formfactor::testing::check_reciprocity;
using formfactor::testing::check_row_sums;
using formfactor::testing::data;
using formfactor::testing::input_error;
using formfactor::testing::read_text;
using formfactor::testing::scratch_dir;
using formfactor::testing::tight_analytic;

namespace {

const std::string kIdf = "energyplus/1ZoneUncontrolled_win_1.idf";
const std::string kEpJson = "energyplus/1ZoneUncontrolled_win_1.epJSON";

std::string replaced(std::string s, const std::string& from, const std::string& to) {
    for (std::size_t at = 0; (at = s.find(from, at)) != std::string::npos; at += to.size())
        s.replace(at, from.size(), to);
    return s;
}

}  // namespace

TEST_CASE("energyplus: EnergyPlus's one-zone example reads as 7 surfaces, the window a hole") {
    const Scene s = load_scene(data(kIdf));
    CHECK(s.title == "ZONE ONE");
    CHECK(s.enclosure);
    REQUIRE(s.surfaces.size() == 7);
    const char* names[] = {"Zn001:Wall001", "Zn001:Wall001:Win001", "Zn001:Wall002",
                           "Zn001:Wall003", "Zn001:Wall004",        "Zn001:Flr001",
                           "Zn001:Roof001"};
    for (std::size_t k = 0; k < 7; ++k) CHECK(s.surfaces[k].name == names[k]);
    CHECK(s.surfaces[1].base == 0);
    REQUIRE(s.surfaces[0].holes.size() == 1);
    // Wall 15.24 × 4.572 minus the 5 × 2 window.
    CHECK(std::abs(surface_area(s.surfaces[0]) - (15.24 * 4.572 - 10.0)) < 1e-9);
    // Every surface faces into the zone (its centre is (7.62, 7.62, 2.286)).
    const Vec3 centre(7.62, 7.62, 2.286);
    for (const Surface& f : s.surfaces)
        CHECK(normal(f.polygon).dot(centre - centroid(f.polygon)) > 0.0);
}

TEST_CASE("energyplus: the zone's rows sum to 1 and reciprocity holds, per patch and surface") {
    Scene s = load_scene(data(kIdf));
    subdivide(s, SubdivisionOptions{2, 0.0});
    const FormFactors f = tight_analytic(s);
    check_enclosure_rows(f);
    const FormFactors g = aggregate_per_surface(s, f);
    REQUIRE(g.size() == 7);
    check_enclosure_rows(g);
}

TEST_CASE("energyplus: the same zone as IDF and epJSON gives the same matrix to 1e-12") {
    const Scene a = load_scene(data(kIdf));
    const Scene b = load_scene(data(kEpJson));
    REQUIRE(a.surfaces.size() == b.surfaces.size());
    for (std::size_t k = 0; k < a.surfaces.size(); ++k)
        CHECK(a.surfaces[k].name == b.surfaces[k].name);
    const FormFactors fa = tight_analytic(a), fb = tight_analytic(b);
    CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
}

TEST_CASE("energyplus: the zone written as VS3 (window as subsurface) gives the same matrix") {
    const Scene a = load_scene(data(kIdf));
    const std::string vs3 = (scratch_dir() / "zone_one.vs3").string();
    save_vs3(a, vs3);
    const Scene b = load_scene(vs3);
    REQUIRE(b.surfaces.size() == a.surfaces.size());
    const FormFactors fa = aggregate_per_surface(a, tight_analytic(a));
    const FormFactors fb = aggregate_per_surface(b, tight_analytic(b));
    REQUIRE(fa.size() == fb.size());
    CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
}

TEST_CASE("energyplus: relative coordinates move the zone to its origin and keep F") {
    const std::string text = read_text(data(kIdf));
    std::string moved = replaced(text, "    World;", "    Relative;");
    moved = replaced(moved,
                     "    0,                       !- X Origin {m}\n"
                     "    0,                       !- Y Origin {m}\n"
                     "    0,                       !- Z Origin {m}",
                     "    10,\n    -20,\n    3,");
    moved = replaced(moved, "    0,                       !- Direction of Relative North {deg}",
                     "    30,");
    const Scene a = load_energyplus_text(text, "a.idf");
    const Scene b = load_energyplus_text(moved, "b.idf");
    // The floor's first vertex (15.24, 0, 0) rotated by -30° about z, then moved.
    const double c = std::cos(-30.0 * M_PI / 180.0), s = std::sin(-30.0 * M_PI / 180.0);
    const Vec3 expected(15.24 * c + 10, 15.24 * s - 20, 3);
    const Polygon& floor = b.surfaces[5].polygon;  // reversed: the first vertex is last
    CHECK((floor.vertices.back() - expected).norm() < 1e-12);
    const FormFactors fa = tight_analytic(a), fb = tight_analytic(b);
    CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
}

TEST_CASE("energyplus: a UTF-8 byte order mark before the first object is skipped") {
    // From the Zone object on: the mark sits right before a class name.
    const std::string full = read_text(data(kIdf));
    const std::string text = full.substr(full.find("Zone,"));
    const Scene a = load_energyplus_text(text, "a.idf");
    const Scene b = load_energyplus_text("\xEF\xBB\xBF" + text, "b.idf");
    REQUIRE(b.surfaces.size() == a.surfaces.size());
    for (std::size_t k = 0; k < a.surfaces.size(); ++k)
        CHECK(b.surfaces[k].polygon.vertices == a.surfaces[k].polygon.vertices);
}

TEST_CASE("energyplus: clockwise vertex entry keeps the file's order (surfaces face outward)") {
    const std::string text = read_text(data(kIdf));
    const Scene cw =
        load_energyplus_text(replaced(text, "CounterClockWise", "Clockwise"), "cw.idf");
    const Vec3 centre(7.62, 7.62, 2.286);
    for (const Surface& f : cw.surfaces)
        CHECK(normal(f.polygon).dot(centre - centroid(f.polygon)) < 0.0);
}

TEST_CASE("energyplus: several zones need --zone, which matches names case-insensitively") {
    const std::string text = read_text(data(kIdf));
    // A second zone: the same room under other names.
    std::string second = text.substr(text.find("  Zone,"));
    second = replaced(second, "ZONE ONE", "Zone Two");
    second = replaced(second, "Zn001", "Zn002");
    second = replaced(second,
                      "  GlobalGeometryRules,\n    UpperLeftCorner,         !- Starting "
                      "Vertex Position\n    CounterClockWise,        !- Vertex Entry "
                      "Direction\n    World;                   !- Coordinate System\n",
                      "");
    const std::string both = text + second;
    CHECK(input_error([&] { load_energyplus_text(both, "two.idf"); }) ==
          "two.idf: the model has 2 zones; choose one with `zone` NAME: ZONE ONE, Zone Two");
    const Scene z2 = load_energyplus_text(both, "two.idf", "zone two");
    CHECK(z2.title == "Zone Two");
    REQUIRE(z2.surfaces.size() == 7);
    CHECK(z2.surfaces[0].name == "Zn002:Wall001");
    CHECK(input_error([&] { load_energyplus_text(both, "two.idf", "Attic"); }) ==
          "two.idf: zone 'Attic' is not in the model (zones: ZONE ONE, Zone Two)");
}

TEST_CASE("energyplus: bad models name the file and line, or the epJSON object") {
    const std::string text = read_text(data(kIdf));
    CHECK(input_error([&] {
              load_energyplus_text(replaced(text, "15.24000,0,0,  !- X,Y,Z ==> Vertex 3",
                                            "15.24000,x,0,  !- X,Y,Z ==> Vertex 3"),
                                   "m.idf");
          }) ==
          "m.idf:56: BuildingSurface:Detailed 'Zn001:Wall001': vertex 3 Y-coordinate 'x' "
          "is not a finite number");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(text,
                                            "    4,                       !- Number of "
                                            "Vertices\n    0,0,4.572000,",
                                            "    5,\n    0,0,4.572000,"),
                                   "m.idf");
          }) ==
          "m.idf:53: BuildingSurface:Detailed 'Zn001:Wall001': Number of Vertices is '5' "
          "but 4 vertices follow");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(text,
                                            "    Zn001:Wall001,           !- Building "
                                            "Surface Name",
                                            "    Zn001:Wall009,"),
                                   "m.idf");
          }) ==
          "m.idf:59: FenestrationSurface:Detailed 'Zn001:Wall001:Win001': its base surface "
          "'Zn001:Wall009' does not exist");
    CHECK(input_error([&] {
              load_energyplus_text(
                  replaced(replaced(text, ",0,2.5000", ",0.3,2.5000"), ",0,0.5000", ",0.3,0.5000"),
                  "m.idf");
          }) ==
          "m.idf:59: FenestrationSurface:Detailed 'Zn001:Wall001:Win001' is not in the plane "
          "of its base surface 'Zn001:Wall001' (distance 0.3)");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(text, "5.548000,0,0.5000,", "25.548000,0,0.5000,"),
                                   "m.idf");
          }).find("is not within its base surface 'Zn001:Wall001'") != std::string::npos);
    CHECK(input_error([&] { load_energyplus_text(text.substr(0, text.rfind(';')), "m.idf"); }) ==
          "m.idf:154: object 'Output:Surfaces:Drawing' is not ended by ';'");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(text, "CounterClockWise", "Sideways"), "m.idf");
          }) ==
          "m.idf:40: GlobalGeometryRules: Vertex Entry Direction 'Sideways' is not one of "
          "Counterclockwise, Clockwise");
    CHECK(input_error([&] { load_energyplus_text("Version, 99000000.5;\n" + text, "m.idf"); }) ==
          "m.idf:1: Version: version '99000000.5' is not an EnergyPlus version number "
          "(major.minor, e.g. 9.6 or 23.2)");
    const std::string json = read_text(data(kEpJson));
    CHECK(input_error([&] {
              load_energyplus_text(replaced(json, "\"vertex_y_coordinate\": 0.0", "\"q\": 0.0"),
                                   "m.epJSON");
          }) ==
          "m.epJSON: BuildingSurface:Detailed 'Zn001:Wall001': vertex 1 has no finite "
          "vertex_y_coordinate");
    CHECK(input_error([&] { load_energyplus_text("{", "m.epJSON"); })
              .rfind("m.epJSON: not valid "
                     "JSON",
                     0) == 0);
}

TEST_CASE("energyplus: NREL's 5ZoneAirCooled: six closed zones, rows sum to 1, reciprocity") {
    // Relative coordinates, windows and glass doors, interzone walls, a return plenum over the
    // five rooms, and overhangs (Shading:Zone:Detailed), which are outside every enclosure.
    const std::string path = data("energyplus/5ZoneAirCooled.idf");
    const std::vector<std::string> zones = energyplus_zones(path);
    REQUIRE(zones == std::vector<std::string>{"PLENUM-1", "SPACE1-1", "SPACE2-1", "SPACE3-1",
                                              "SPACE4-1", "SPACE5-1"});
    const std::size_t surfaces[] = {10, 8, 7, 8, 7, 6};
    for (std::size_t z = 0; z < zones.size(); ++z) {
        INFO(zones[z]);
        const Scene s = load_energyplus(path, zones[z]);
        CHECK(s.title == zones[z]);
        CHECK(s.enclosure);
        CHECK(s.surfaces.size() == surfaces[z]);
        for (const Surface& f : s.surfaces) CHECK(f.name.find("Overhang") == std::string::npos);
        const FormFactors f = tight_analytic(s);
        check_enclosure_rows(f);
    }
    // The south room: its window and glass door are holes of FRONT-1, which keeps what is left
    // of 30.5 × 2.4.
    const Scene south = load_energyplus(path, "space1-1");
    REQUIRE(south.surfaces.size() == 8);
    CHECK(south.surfaces[0].name == "FRONT-1");
    CHECK(south.surfaces[1].name == "WF-1");
    CHECK(south.surfaces[2].name == "DF-1");
    CHECK(south.surfaces[0].holes.size() == 2);
    CHECK(std::abs(surface_area(south.surfaces[0]) - (30.5 * 2.4 - 13.8 * 1.2 - 2.5 * 2.1)) < 1e-9);
}

TEST_CASE("energyplus: NREL's 5ZoneAirCooled as IDF and epJSON gives the same matrices") {
    const std::string idf = data("energyplus/5ZoneAirCooled.idf");
    const std::string json = data("energyplus/5ZoneAirCooled.epJSON");
    REQUIRE(energyplus_zones(json) == energyplus_zones(idf));
    for (const std::string& zone : energyplus_zones(idf)) {
        INFO(zone);
        const Scene a = load_energyplus(idf, zone);
        const Scene b = load_energyplus(json, zone);
        REQUIRE(a.surfaces.size() == b.surfaces.size());
        for (std::size_t k = 0; k < a.surfaces.size(); ++k)
            CHECK(a.surfaces[k].name == b.surfaces[k].name);
        const FormFactors fa = tight_analytic(a), fb = tight_analytic(b);
        CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
    }
}

TEST_CASE("energyplus: NREL's small office: six closed zones, a hip-roofed attic, areas as drawn") {
    // DOE's reference small office: four trapezoidal perimeter zones around a core, 20 windows
    // and a glass door, an attic whose hip roof has triangular ends and whose eaves close it
    // with soffits; world-aligned zones in relative coordinates, upper-left starting corners.
    const std::string path = data("energyplus/RefBldgSmallOfficeNew2004_Chicago.idf");
    const std::vector<std::string> zones = energyplus_zones(path);
    REQUIRE(zones == std::vector<std::string>{"Attic", "Core_ZN", "Perimeter_ZN_1",
                                              "Perimeter_ZN_2", "Perimeter_ZN_3",
                                              "Perimeter_ZN_4"});
    const std::size_t surfaces[] = {13, 6, 13, 10, 12, 10};  // windows and doors are surfaces
    double floors = 0.0;
    for (std::size_t z = 0; z < zones.size(); ++z) {
        INFO(zones[z]);
        const Scene s = load_energyplus(path, zones[z]);
        CHECK(s.enclosure);
        CHECK(s.surfaces.size() == surfaces[z]);
        for (const Surface& f : s.surfaces)
            if (z > 0 && f.name.size() > 6 && f.name.substr(f.name.size() - 6) == "_floor")
                floors += surface_area(f);
        check_enclosure_rows(tight_analytic(s));
    }
    // The five rooms' floors tile the 27.69 m × 18.46 m footprint.
    CHECK(std::abs(floors - 27.69 * 18.46) < 1e-9);

    // The attic's floor: the rooms' ceilings and the 0.6 m eaves' soffits, 28.89 m × 19.66 m.
    const Scene attic = load_energyplus(path, "attic");
    double horizontal = 0.0;
    for (const Surface& f : attic.surfaces)
        if (f.name.find("_floor_") != std::string::npos ||
            f.name.find("_soffit_") != std::string::npos)
            horizontal += surface_area(f);
    CHECK(std::abs(horizontal - 28.89 * 19.66) < 1e-9);

    // The south room: six 1.83 m × 1.524 m windows and a 1.83 m × 2.134 m glass door cut out of
    // its 27.69 m × 3.05 m wall.
    const Scene south = load_energyplus(path, "Perimeter_ZN_1");
    const auto wall =
        std::find_if(south.surfaces.begin(), south.surfaces.end(),
                     [](const Surface& f) { return f.name == "Perimeter_ZN_1_wall_south"; });
    REQUIRE(wall != south.surfaces.end());
    CHECK(wall->holes.size() == 7);
    CHECK(std::abs(surface_area(*wall) - (27.69 * 3.05 - 6 * 1.83 * 1.524 - 1.83 * 2.134)) < 1e-9);
}

TEST_CASE("energyplus: NREL's three-surface zone reads in world coordinates and is left open") {
    // EnergyPlus's test of a zone that does not close (a 60.96 m wall, a 15.24 m square floor and
    // roof): read as drawn, its rows sum to less than 1 (energy leaves through the missing
    // walls), and reciprocity still holds.
    const Scene s = load_energyplus(data("energyplus/1ZoneUncontrolled3SurfaceZone.idf"));
    REQUIRE(s.surfaces.size() == 3);
    CHECK(std::abs(surface_area(s.surfaces[0]) - 60.96 * 4.572) < 1e-9);
    const FormFactors f = tight_analytic(s);
    check_row_sums(f.F, 0.5, 0.4);  // every row in (0.1, 0.9): open, yet each sees the rest
    check_reciprocity(f, 1e-10);
    // Floor and roof: parallel 15.24 m squares 4.572 m apart (Howell's C-11, X = Y = 10/3).
    const double X = 15.24 / 4.572, x = std::sqrt(1 + X * X);
    const double parallel = 1.0 / (M_PI * X * X) *
                            (std::log(x * x * x * x / (1 + 2 * X * X)) +
                             4 * X * x * std::atan(X / x) - 4 * X * std::atan(X));
    CHECK(std::abs(f.F(1, 2) - parallel) < 1e-9);
}

TEST_CASE("energyplus: NREL's small office (Version 8.3 windows) as IDF and epJSON agrees") {
    // Its windows have the Shading Control Name field of EnergyPlus before 9.0, which the epJSON
    // twin (9.0 and later) does not: both give the same surfaces and matrices.
    const std::string idf = data("energyplus/RefBldgSmallOfficeNew2004_Chicago.idf");
    const std::string json = data("energyplus/RefBldgSmallOfficeNew2004_Chicago.epJSON");
    REQUIRE(energyplus_zones(json) == energyplus_zones(idf));
    for (const std::string& zone : energyplus_zones(idf)) {
        INFO(zone);
        const Scene a = load_energyplus(idf, zone);
        const Scene b = load_energyplus(json, zone);
        REQUIRE(a.surfaces.size() == b.surfaces.size());
        for (std::size_t k = 0; k < a.surfaces.size(); ++k) {
            CHECK(a.surfaces[k].name == b.surfaces[k].name);
            CHECK(std::abs(surface_area(a.surfaces[k]) - surface_area(b.surfaces[k])) < 1e-12);
        }
        const FormFactors fa = tight_analytic(a), fb = tight_analytic(b);
        CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
    }
}

namespace {

// One room, 4 × 3 × 2.5 m, with a window in its south wall and a door in its east wall, in a
// zone turned by 30° and moved to (2, 3, 1) in a building turned by 15°: `simple` draws it with
// EnergyPlus's simplified objects, `detailed` with the vertices that the Input-Output Reference
// says they stand for (upper left corner first, counter-clockwise seen from outside).
const std::string kRoomHead =
    "Version, 9.3;\n"
    "Building, Room, 15;\n"
    "Zone, ROOM, 30, 2, 3, 1;\n"
    "GlobalGeometryRules, UpperLeftCorner, Counterclockwise, Relative, Relative, Relative;\n";

const std::string kRoomSimple =
    "Wall:Exterior, South, C, ROOM, 180, 90, 0, 0, 0, 4, 2.5;\n"
    "Window, South window, G, South, , 1, 1, 0.8, 1.5, 1;\n"
    "Wall:Adiabatic, East, C, ROOM, 90, 90, 4, 0, 0, 3, 2.5;\n"
    "Door, East door, D, East, 1, 0.5, 0, 1, 2;\n"
    "Wall:Interzone, North, C, ROOM, ROOM, 0, 90, 4, 3, 0, 4, 2.5;\n"
    "Wall:Underground, West, C, ROOM, 270, , 0, 3, 0, 3, 2.5;\n"
    "Floor:GroundContact, Floor, C, ROOM, 0, , 4, 0, 0, 4, 3;\n"
    "Roof, Roof, C, ROOM, 180, , 0, 0, 2.5, 4, 3;\n";

std::string detailed_wall(const std::string& name, const std::string& coords) {
    return "BuildingSurface:Detailed, " + name + ", Wall, C, ROOM, Outdoors, , , , , 4, " + coords +
           ";\n";
}

const std::string kRoomDetailed =
    detailed_wall("South", "0,0,2.5, 0,0,0, 4,0,0, 4,0,2.5") +
    "FenestrationSurface:Detailed, South window, Window, G, South, , , , 1, 4, "
    "1,0,1.8, 1,0,0.8, 2.5,0,0.8, 2.5,0,1.8;\n" +
    detailed_wall("East", "4,0,2.5, 4,0,0, 4,3,0, 4,3,2.5") +
    "FenestrationSurface:Detailed, East door, Door, D, East, , , , 1, 4, "
    "4,0.5,2, 4,0.5,0, 4,1.5,0, 4,1.5,2;\n" +
    detailed_wall("North", "4,3,2.5, 4,3,0, 0,3,0, 0,3,2.5") +
    detailed_wall("West", "0,3,2.5, 0,3,0, 0,0,0, 0,0,2.5") +
    detailed_wall("Floor", "4,3,0, 4,0,0, 0,0,0, 0,3,0") +
    detailed_wall("Roof", "0,3,2.5, 0,0,2.5, 4,0,2.5, 4,3,2.5");

// Surfaces (and F) by name: epJSON lists objects by class, IDF in file order.
const Surface& named(const Scene& s, const std::string& name) {
    for (const Surface& f : s.surfaces)
        if (f.name == name) return f;
    FAIL("no surface " << name);
    return s.surfaces.front();
}

}  // namespace

TEST_CASE("energyplus: simplified objects give the patches of the same room drawn in detail") {
    const Scene simple = load_energyplus_text(kRoomHead + kRoomSimple, "simple.idf");
    const Scene detailed = load_energyplus_text(kRoomHead + kRoomDetailed, "detailed.idf");
    REQUIRE(simple.surfaces.size() == 8);
    REQUIRE(detailed.surfaces.size() == 8);
    for (std::size_t k = 0; k < 8; ++k) {
        const Surface& a = simple.surfaces[k];
        const Surface& b = detailed.surfaces[k];
        INFO(a.name);
        CHECK(a.name == b.name);
        CHECK(a.base == b.base);
        REQUIRE(a.polygon.size() == b.polygon.size());
        for (std::size_t v = 0; v < a.polygon.size(); ++v)
            CHECK((a.polygon[v] - b.polygon[v]).norm() < 1e-12);
        CHECK((normal(a.polygon) - normal(b.polygon)).norm() < 1e-12);
        CHECK(std::abs(surface_area(a) - surface_area(b)) < 1e-12);
        REQUIRE(a.holes.size() == b.holes.size());
    }
    CHECK(std::abs(surface_area(simple.surfaces[0]) - (4 * 2.5 - 1.5)) < 1e-12);
    CHECK(std::abs(surface_area(simple.surfaces[2]) - (3 * 2.5 - 2)) < 1e-12);
    const FormFactors fa = tight_analytic(simple), fb = tight_analytic(detailed);
    CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
    check_enclosure_rows(fa);
}

TEST_CASE(
    "energyplus: simplified windows and doors on detailed walls are cut where EnergyPlus puts "
    "them") {
    // The detailed room with its window and door written as Window and Door on the detailed
    // walls (Starting X and Z from the wall's second vertex, its lower left corner): the same
    // holes, so the same patches and the same matrix, in a zone turned and moved.
    const std::string window_detailed =
        "FenestrationSurface:Detailed, South window, Window, G, South, , , , 1, 4, "
        "1,0,1.8, 1,0,0.8, 2.5,0,0.8, 2.5,0,1.8;";
    const std::string door_detailed =
        "FenestrationSurface:Detailed, East door, Door, D, East, , , , 1, 4, "
        "4,0.5,2, 4,0.5,0, 4,1.5,0, 4,1.5,2;";
    REQUIRE(kRoomDetailed.find(window_detailed) != std::string::npos);
    REQUIRE(kRoomDetailed.find(door_detailed) != std::string::npos);
    const std::string openings =
        replaced(replaced(kRoomDetailed, window_detailed,
                          "Window, South window, G, South, , 1, 1, 0.8, 1.5, 1;"),
                 door_detailed, "Door, East door, D, East, 1, 0.5, 0, 1, 2;");
    const Scene simple = load_energyplus_text(kRoomHead + openings, "simple.idf");
    const Scene detailed = load_energyplus_text(kRoomHead + kRoomDetailed, "detailed.idf");
    REQUIRE(simple.surfaces.size() == 8);
    for (std::size_t k = 0; k < 8; ++k) {
        const Surface& a = simple.surfaces[k];
        const Surface& b = detailed.surfaces[k];
        INFO(a.name);
        CHECK(a.name == b.name);
        CHECK(a.base == b.base);
        REQUIRE(a.polygon.size() == b.polygon.size());
        for (std::size_t v = 0; v < a.polygon.size(); ++v)
            CHECK((a.polygon[v] - b.polygon[v]).norm() < 1e-12);
        CHECK(std::abs(surface_area(a) - surface_area(b)) < 1e-12);
    }
    CHECK(std::abs(surface_area(named(simple, "South")) - (4 * 2.5 - 1.5)) < 1e-12);
    CHECK(std::abs(surface_area(named(simple, "East")) - (3 * 2.5 - 2)) < 1e-12);
    const FormFactors fa = tight_analytic(simple), fb = tight_analytic(detailed);
    CHECK((fa.F - fb.F).cwiseAbs().maxCoeff() <= 1e-12);
    check_enclosure_rows(fa);

    // A skylight on the detailed roof (horizontal: X runs along the edge from vertex 2 to 3),
    // and a window on a wall entered clockwise (the order turned round from vertex 1, so that
    // vertex 2 is the last one entered: the lower left corner), in world coordinates.
    const std::string head =
        "Version, 9.3;\nZone, ROOM;\n"
        "GlobalGeometryRules, UpperLeftCorner, Clockwise, World;\n";
    auto wall = [](const std::string& name, const std::string& coords) {
        return "BuildingSurface:Detailed, " + name + ", Wall, C, ROOM, Outdoors, , , , , 4, " +
               coords + ";\n";
    };
    const std::string room = wall("South", "0,0,2.5, 4,0,2.5, 4,0,0, 0,0,0") +
                             "Window, SW, G, South, , 1, 1, 0.8, 1.5, 1;\n" +
                             wall("East", "4,0,2.5, 4,3,2.5, 4,3,0, 4,0,0") +
                             wall("North", "4,3,2.5, 0,3,2.5, 0,3,0, 4,3,0") +
                             wall("West", "0,3,2.5, 0,0,2.5, 0,0,0, 0,3,0") +
                             wall("Floor", "4,3,0, 0,3,0, 0,0,0, 4,0,0") +
                             wall("Roof", "0,3,2.5, 4,3,2.5, 4,0,2.5, 0,0,2.5") +
                             "Window, Skylight, G, Roof, , 1, 1, 1, 1, 0.5;\n";
    const Scene c = load_energyplus_text(head + room, "cw.idf");
    REQUIRE(c.surfaces.size() == 8);
    const Surface& sky = named(c, "Skylight");
    REQUIRE(named(c, "Roof").holes.size() == 1);
    CHECK(std::abs(surface_area(named(c, "Roof")) - (12 - 0.5)) < 1e-12);
    CHECK((centroid(sky.polygon) - Vec3(1.5, 1.25, 2.5)).norm() < 1e-12);
    CHECK(normal(sky.polygon).z() < -1 + 1e-12);  // faces into the room, like its roof
    const Surface& sw = named(c, "SW");
    CHECK(std::abs(surface_area(sw) - 1.5) < 1e-12);
    CHECK((centroid(sw.polygon) - Vec3(1.75, 0, 1.3)).norm() < 1e-12);
    CHECK(std::abs(surface_area(named(c, "South")) - (10 - 1.5)) < 1e-12);
    check_enclosure_rows(tight_analytic(c));
}

TEST_CASE("energyplus: an interzone surface that names a zone makes its facing surface there") {
    // Two rooms side by side, 4 × 3 × 2.5 m each; A's east wall (x = 4) names zone B as its
    // outside, with a window in it; B draws no west wall: EnergyPlus makes "iz-" surfaces in B,
    // the vertices reversed, and so does formfactor, so that B is closed.
    const std::string head =
        "Version, 9.3;\nZone, A;\nZone, B;\n"
        "GlobalGeometryRules, UpperLeftCorner, Counterclockwise, Relative;\n";
    auto surface = [](const std::string& name, const std::string& zone, const std::string& coords,
                      const std::string& outside = "Outdoors, ") {
        return "BuildingSurface:Detailed, " + name + ", Wall, C, " + zone + ", " + outside +
               ", , , , 4, " + coords + ";\n";
    };
    const std::string a = surface("A south", "A", "0,0,2.5, 0,0,0, 4,0,0, 4,0,2.5") +
                          surface("A north", "A", "4,3,2.5, 4,3,0, 0,3,0, 0,3,2.5") +
                          surface("A west", "A", "0,3,2.5, 0,3,0, 0,0,0, 0,0,2.5") +
                          surface("A floor", "A", "4,3,0, 4,0,0, 0,0,0, 0,3,0") +
                          surface("A roof", "A", "0,3,2.5, 0,0,2.5, 4,0,2.5, 4,3,2.5");
    const std::string b = surface("B south", "B", "4,0,2.5, 4,0,0, 8,0,0, 8,0,2.5") +
                          surface("B east", "B", "8,0,2.5, 8,0,0, 8,3,0, 8,3,2.5") +
                          surface("B north", "B", "8,3,2.5, 8,3,0, 4,3,0, 4,3,2.5") +
                          surface("B floor", "B", "8,3,0, 8,0,0, 4,0,0, 4,3,0") +
                          surface("B roof", "B", "4,3,2.5, 4,0,2.5, 8,0,2.5, 8,3,2.5");
    const std::string detailed =
        head + a + surface("A east", "A", "4,0,2.5, 4,0,0, 4,3,0, 4,3,2.5", "Zone, B") +
        "Window:Interzone, AB window, G, A east, B, 1, 1, 0.8, 1.5, 1;\n" + b;
    const std::string simplified =
        head + a + "Wall:Interzone, A east, C, A, B, 90, 90, 4, 0, 0, 3, 2.5;\n" +
        "Window:Interzone, AB window, G, A east, B, 1, 1, 0.8, 1.5, 1;\n" + b;
    for (const std::string& text : {detailed, simplified}) {
        const Scene sa = load_energyplus_text(text, "two.idf", "A");
        REQUIRE(sa.surfaces.size() == 7);
        check_enclosure_rows(tight_analytic(sa));
        const Scene sb = load_energyplus_text(text, "two.idf", "B");
        REQUIRE(sb.surfaces.size() == 7);
        CHECK(sb.surfaces[5].name == "iz-A east");
        CHECK(sb.surfaces[6].name == "iz-AB window");
        CHECK(sb.surfaces[6].base == 5);
        const Surface& wall = named(sb, "iz-A east");
        const Surface& facing = named(sa, "A east");
        CHECK(std::abs(surface_area(wall) - (7.5 - 1.5)) < 1e-12);
        // The same rectangle as A's wall, facing the other way: into B (+x).
        CHECK((normal(wall.polygon) - Vec3(1, 0, 0)).norm() < 1e-12);
        CHECK((normal(facing.polygon) + Vec3(1, 0, 0)).norm() < 1e-12);
        CHECK((centroid(wall.polygon) - centroid(facing.polygon)).norm() < 1e-12);
        const Surface& window = named(sb, "iz-AB window");
        CHECK(std::abs(surface_area(window) - 1.5) < 1e-12);
        CHECK((centroid(window.polygon) - centroid(named(sa, "AB window").polygon)).norm() < 1e-12);
        CHECK((centroid(window.polygon) - Vec3(4, 1.75, 1.3)).norm() < 1e-12);
        check_enclosure_rows(tight_analytic(sb));
    }
    // The model also draws the wall that EnergyPlus generates: refused, not counted twice.
    const std::string twice = detailed + surface("B west", "B", "4,3,2.5, 4,3,0, 4,0,0, 4,0,2.5");
    CHECK(load_energyplus_text(twice, "two.idf", "A").surfaces.size() == 7);
    CHECK(input_error([&] { load_energyplus_text(twice, "two.idf", "B"); }) ==
          "two.idf:10: BuildingSurface:Detailed 'A east' names zone 'B' as its outside, where "
          "EnergyPlus generates 'iz-A east'; but that zone's surface 'B west' already covers it "
          "(name the surface, not the zone, as the Outside Boundary Condition Object)");
    // A condition Zone whose object is not a zone of the model.
    CHECK(input_error([&] {
              load_energyplus_text(replaced(detailed, "Zone, B,", "Zone, C,"), "two.idf", "A");
          }) ==
          "two.idf:10: BuildingSurface:Detailed 'A east': Outside Boundary Condition Object "
          "'C' is not a zone of the model (the condition is Zone)");
}

TEST_CASE(
    "energyplus: the two zones as epJSON: a window on a detailed wall, its zone's facing "
    "surfaces") {
    // A's east wall (condition Zone, object B) with a Window:Interzone, and B's five surfaces,
    // as epJSON writes them (objects grouped by class, vertices in "vertices" arrays).
    auto surface = [](const std::string& name, const std::string& zone, const std::vector<Vec3>& v,
                      const std::string& outside) {
        std::string s = "\"" + name +
                        "\": {\"surface_type\": \"Wall\", \"construction_name\": "
                        "\"C\", \"zone_name\": \"" +
                        zone + "\", " + outside + "\"vertices\": [";
        for (std::size_t k = 0; k < v.size(); ++k)
            s += (k ? ", " : "") + std::string("{\"vertex_x_coordinate\": ") +
                 std::to_string(v[k].x()) +
                 ", \"vertex_y_coordinate\": " + std::to_string(v[k].y()) +
                 ", \"vertex_z_coordinate\": " + std::to_string(v[k].z()) + "}";
        return s + "]}";
    };
    const std::string out = "\"outside_boundary_condition\": \"Outdoors\", ";
    const std::string text =
        "{\"Version\": {\"Version 1\": {\"version_identifier\": \"23.2\"}},\n"
        "\"Zone\": {\"A\": {}, \"B\": {}},\n"
        "\"BuildingSurface:Detailed\": {\n" +
        surface("A east", "A", {{4, 0, 2.5}, {4, 0, 0}, {4, 3, 0}, {4, 3, 2.5}},
                "\"outside_boundary_condition\": \"Zone\", "
                "\"outside_boundary_condition_object\": \"B\", ") +
        ",\n" + surface("B south", "B", {{4, 0, 2.5}, {4, 0, 0}, {8, 0, 0}, {8, 0, 2.5}}, out) +
        ",\n" + surface("B east", "B", {{8, 0, 2.5}, {8, 0, 0}, {8, 3, 0}, {8, 3, 2.5}}, out) +
        ",\n" + surface("B north", "B", {{8, 3, 2.5}, {8, 3, 0}, {4, 3, 0}, {4, 3, 2.5}}, out) +
        ",\n" + surface("B floor", "B", {{8, 3, 0}, {8, 0, 0}, {4, 0, 0}, {4, 3, 0}}, out) + ",\n" +
        surface("B roof", "B", {{4, 3, 2.5}, {4, 0, 2.5}, {8, 0, 2.5}, {8, 3, 2.5}}, out) +
        "},\n"
        "\"Window:Interzone\": {\"AB window\": {\"construction_name\": \"G\", "
        "\"building_surface_name\": \"A east\", \"outside_boundary_condition_object\": \"B\", "
        "\"multiplier\": 1, \"starting_x_coordinate\": 1, \"starting_z_coordinate\": 0.8, "
        "\"length\": 1.5, \"height\": 1}}}\n";
    const Scene b = load_energyplus_text(text, "two.epJSON", "B");
    REQUIRE(b.surfaces.size() == 7);
    CHECK(b.surfaces[5].name == "iz-A east");
    CHECK(b.surfaces[6].name == "iz-AB window");
    CHECK((centroid(b.surfaces[6].polygon) - Vec3(4, 1.75, 1.3)).norm() < 1e-12);
    CHECK((normal(b.surfaces[5].polygon) - Vec3(1, 0, 0)).norm() < 1e-12);
    CHECK(std::abs(surface_area(b.surfaces[5]) - 6.0) < 1e-12);
    check_enclosure_rows(tight_analytic(b));
    CHECK(input_error([&] {
              load_energyplus_text(
                  replaced(text, "\"outside_boundary_condition_object\": \"B\", \"v",
                           "\"outside_boundary_condition_object\": \"C\", \"v"),
                  "two.epJSON", "B");
          }) ==
          "two.epJSON: BuildingSurface:Detailed 'A east': Outside Boundary Condition Object "
          "'C' is not a zone of the model (the condition is Zone)");
}

TEST_CASE("energyplus: a simplified wall's azimuth turns with the building and the zone north") {
    // The south wall's outward normal points to azimuth 180 + 15 + 30 = 225 (south-west); the
    // room's surfaces face inward, so its normal points to azimuth 45: (sin 45°, cos 45°, 0).
    const Scene s = load_energyplus_text(kRoomHead + kRoomSimple, "simple.idf");
    const double r = std::sqrt(0.5);
    CHECK((normal(s.surfaces[0].polygon) - Vec3(r, r, 0)).norm() < 1e-12);
    // Its lower left corner is the zone origin (2, 3, 1) turned by the building's 15°.
    const double c = std::cos(-15.0 * M_PI / 180.0), n = std::sin(-15.0 * M_PI / 180.0);
    const Vec3 corner(2 * c - 3 * n, 2 * n + 3 * c, 1);
    CHECK((s.surfaces[0].polygon.vertices[2] - corner).norm() < 1e-12);  // reversed: LLC third
    // World coordinates keep the azimuth as given; World rectangles keep the corner as given.
    const Scene w = load_energyplus_text(
        replaced(kRoomHead, "Relative, Relative, Relative", "World, Relative, Relative") +
            kRoomSimple,
        "world.idf");
    CHECK((normal(w.surfaces[0].polygon) - Vec3(0, 1, 0)).norm() < 1e-12);
    CHECK((w.surfaces[0].polygon.vertices[2] - corner).norm() < 1e-12);
    const Scene wr = load_energyplus_text(
        replaced(kRoomHead, "Relative, Relative, Relative", "Relative, Relative, World") +
            kRoomSimple,
        "world_rect.idf");
    CHECK((normal(wr.surfaces[0].polygon) - Vec3(r, r, 0)).norm() < 1e-12);
    CHECK((wr.surfaces[0].polygon.vertices[2] - Vec3(0, 0, 0)).norm() < 1e-12);
}

TEST_CASE("energyplus: NREL's simplified four-zone example: closed zones placed at their origins") {
    // Wall:Exterior, Wall:Adiabatic, Wall:Interzone, Floor:Adiabatic, Floor:Interzone,
    // Ceiling:Interzone, Roof, Window, Door and Window:Interzone; World coordinates with
    // rectangles relative to their zones' origins (6, 6, 0), (26, 6, 0), (6, 6, 10), (26, 6, 10).
    const std::string path = data("energyplus/4ZoneWithShading_Simple_1.idf");
    const std::vector<std::string> zones = energyplus_zones(path);
    REQUIRE(zones == std::vector<std::string>{"ZONE 1", "ZONE 2", "ZONE 3", "ZONE 4"});
    const std::size_t surfaces[] = {8, 9, 8, 8};
    for (std::size_t z = 0; z < zones.size(); ++z) {
        INFO(zones[z]);
        const Scene s = load_energyplus(path, zones[z]);
        CHECK(s.surfaces.size() == surfaces[z]);
        for (const Surface& f : s.surfaces) CHECK(f.name.find("Shade") == std::string::npos);
        check_enclosure_rows(tight_analytic(s));
    }
    const Scene one = load_energyplus(path, "ZONE 1");
    const Surface& south = named(one, "Zn001:Wall001");
    CHECK(south.holes.size() == 2);  // a window and a door
    CHECK(std::abs(surface_area(south) - (20 * 10 - 3 * 5 - 3 * 5)) < 1e-9);
    CHECK((normal(south.polygon) - Vec3(0, 1, 0)).norm() < 1e-12);
    const Polygon& window = named(one, "Zn001:Wall001:Win001").polygon;
    const Polygon expected_window{{Vec3(13, 6, 8), Vec3(13, 6, 3), Vec3(10, 6, 3), Vec3(10, 6, 8)}};
    CHECK(formfactor::testing::same_cycle(window, expected_window));
    // Zone 1's ceiling is zone 3's floor, and the interzone windows of zones 3 and 4 are one
    // rectangle seen from both sides.
    const Scene three = load_energyplus(path, "ZONE 3");
    const Scene four = load_energyplus(path, "ZONE 4");
    Polygon ceiling = named(one, "Zn001:Roof001").polygon;
    std::reverse(ceiling.vertices.begin(), ceiling.vertices.end());
    CHECK(formfactor::testing::same_cycle(ceiling, named(three, "Zn003:Flr001").polygon));
    Polygon izw = named(three, "Zn003:Wall004:Win001").polygon;
    std::reverse(izw.vertices.begin(), izw.vertices.end());
    CHECK(formfactor::testing::same_cycle(izw, named(four, "Zn004:Wall004:Win001").polygon));
    CHECK((normal(izw) - Vec3(1, 0, 0)).norm() < 1e-12);  // zone 4 is east of zone 3
}

TEST_CASE("energyplus: NREL's simplified four-zone example as IDF and epJSON agrees") {
    const std::string idf = data("energyplus/4ZoneWithShading_Simple_1.idf");
    const std::string json = data("energyplus/4ZoneWithShading_Simple_1.epJSON");
    REQUIRE(energyplus_zones(json) == energyplus_zones(idf));
    for (const std::string& zone : energyplus_zones(idf)) {
        INFO(zone);
        const Scene a = load_energyplus(idf, zone);
        const Scene b = load_energyplus(json, zone);
        REQUIRE(a.surfaces.size() == b.surfaces.size());
        const FormFactors fa = aggregate_per_surface(a, tight_analytic(a));
        const FormFactors fb = aggregate_per_surface(b, tight_analytic(b));
        REQUIRE(static_cast<std::size_t>(fa.F.rows()) == a.surfaces.size());
        std::vector<Eigen::Index> in_b;  // b's index of each of a's surfaces
        for (const Surface& f : a.surfaces) {
            const Surface& g = named(b, f.name);
            CHECK(formfactor::testing::same_cycle(f.polygon, g.polygon));
            in_b.push_back(&g - b.surfaces.data());
        }
        double worst = 0.0;
        for (Eigen::Index i = 0; i < fa.F.rows(); ++i)
            for (Eigen::Index j = 0; j < fa.F.cols(); ++j)
                worst =
                    std::max(worst, std::abs(fa.F(i, j) - fb.F(in_b[static_cast<std::size_t>(i)],
                                                               in_b[static_cast<std::size_t>(j)])));
        CHECK(worst <= 1e-12);
    }
}

TEST_CASE("energyplus: bad simplified objects name the file and line and the object") {
    const std::string room = kRoomHead + kRoomSimple;
    CHECK(input_error([&] {
              load_energyplus_text(
                  replaced(room, "180, 90, 0, 0, 0, 4, 2.5", "180, 90, 0, 0, 0, -4, 2.5"), "m.idf");
          }) == "m.idf:5: Wall:Exterior 'South': Length '-4' is not positive");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(room, "0, 0, 2.5, 4, 3;", "0, 0, 2.5, 4, 0;"), "m.idf");
          }) == "m.idf:12: Roof 'Roof': Width '0' is not positive");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(room, "1, 1, 0.8, 1.5, 1;", "1, nan, 0.8, 1.5, 1;"),
                                   "m.idf");
          }) ==
          "m.idf:6: Window 'South window': Starting X Coordinate 'nan' is not a finite "
          "number");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(room, "1, 0.5, 0, 1, 2;", "1, 0.5, 0, 1;"), "m.idf");
          }) == "m.idf:8: Door 'East door' has no Height");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(room, "Wall:Underground, West, C, ROOM,",
                                            "Wall:Underground, West, C, HALL,"),
                                   "m.idf");
          }) == "m.idf:10: Wall:Underground 'West': its zone 'HALL' does not exist");
    CHECK(input_error([&] {
              load_energyplus_text(replaced(room, "1, 1, 0.8, 1.5, 1;", "1, 3, 0.8, 1.5, 1;"),
                                   "m.idf");
          }).find("m.idf:6: Window 'South window' is not within its base surface 'South'") == 0);
    // A simplified window on a detailed wall that reaches past its top.
    CHECK(input_error([&] {
              load_energyplus_text(
                  kRoomHead + kRoomDetailed + "Window, W2, G, North, , 1, 1, 2, 1, 1;\n", "m.idf");
          }).find("m.idf:13: Window 'W2' is not within its base surface 'North'") == 0);
    const std::string json = read_text(data("energyplus/4ZoneWithShading_Simple_1.epJSON"));
    CHECK(input_error([&] {
              load_energyplus_text(replaced(json, "\"height\": 10", "\"height\": \"tall\""),
                                   "m.epJSON", "ZONE 1");
          }) ==
          "m.epJSON: Wall:Exterior 'Zn001:Wall001': Height '\"tall\"' is not a finite number");
}

TEST_CASE(
    "energyplus: NREL's second simplified example: zones below grade closed and its flaws found") {
    // Version 9.1 windows (no Shading Control Name), GlazedDoor, Wall:Underground,
    // Floor:GroundContact, Ceiling:Adiabatic; Relative coordinates, zones 1 and 2 below grade.
    const std::string path = data("energyplus/4ZoneWithShading_Simple_2.idf");
    const Scene one = load_energyplus(path, "ZONE 1");
    CHECK(one.surfaces.size() == 9);
    check_enclosure_rows(tight_analytic(one));
    const Surface& south = named(one, "Zn001:Wall001");
    CHECK(south.holes.size() == 2);  // a window and a glass door
    CHECK(std::abs(surface_area(south) - (200 - 15 - 15)) < 1e-9);
    for (const Vec3& v : named(one, "Zn001:Flr001").polygon.vertices)
        CHECK(std::abs(v.z() + 10.0) < 1e-12);
    const Scene two = load_energyplus(path, "ZONE 2");
    CHECK(two.surfaces.size() == 8);
    check_enclosure_rows(tight_analytic(two));
    // Zone 3's interzone wall holds a door and a glass door on the same rectangle.
    CHECK(input_error([&] { load_energyplus(path, "ZONE 3"); }) ==
          path +
              ":353: Door:Interzone 'Zn003:Wall004:Door001' overlaps another subsurface of "
              "'Zn003:Wall004'");
    // Zone 4's west wall is the one EnergyPlus generates from zone 3's Wall:Interzone (whose
    // outside boundary condition object names the zone), with the same door and glass door.
    CHECK(input_error([&] { load_energyplus(path, "ZONE 4"); }) ==
          path +
              ":353: Door:Interzone 'iz-Zn003:Wall004:Door001' overlaps another subsurface of "
              "'iz-Zn003:Wall004'");
    // Without the door, zone 4 is closed by the generated wall and its two openings.
    const std::string text = read_text(path);
    const std::size_t door = text.find("  Door:Interzone,\n    Zn003:Wall004:Door001");
    REQUIRE(door != std::string::npos);
    const std::string without =
        text.substr(0, door) + text.substr(text.find("Floor:Interzone,", door) - 2);
    const Scene four = load_energyplus_text(without, "m.idf", "ZONE 4");
    CHECK(four.surfaces.size() == 9);
    CHECK(named(four, "iz-Zn003:Wall004").holes.size() == 2);
    CHECK(std::abs(surface_area(named(four, "iz-Zn003:Wall004")) -
                   surface_area(named(load_energyplus_text(without, "m.idf", "ZONE 3"),
                                      "Zn003:Wall004"))) < 1e-9);
    check_enclosure_rows(tight_analytic(four));
}
