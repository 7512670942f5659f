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
              load_energyplus_text(text +
                                       "Wall:Exterior, W1, R13WALL, ZONE ONE, 0, 90, 0, 0, "
                                       "0, 3, 3;\n",
                                   "m.idf");
          }) ==
          "m.idf:155: Wall:Exterior 'W1' (simplified geometry) is not read: describe "
          "zone 'ZONE ONE' with BuildingSurface:Detailed and FenestrationSurface:Detailed "
          "objects");
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
