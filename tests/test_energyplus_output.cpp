// ZoneProperty:UserViewFactors:BySurfaceName written by `compute -o X.idf / X.epJSON` for
// EnergyPlus's example zone: read back with the reader's own object parser (IDF) and
// nlohmann-json (epJSON), names, rows and reciprocity checked.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/output/energyplus_view_factors.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/scene/scene.h"
#include "scene/energyplus_objects.h"
#include "support/cli_runner.h"
#include "support/matrix_checks.h"

using namespace formfactor;
using formfactor::testing::check_row_sums;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::read_text;
using formfactor::testing::shell_quote;

namespace {

struct ReadBack {
    std::string zone;
    std::vector<std::string> names;  // in the order of the rows
    std::map<std::pair<std::string, std::string>, double> F;
};

// Every pair once, rows and columns the same names in the same order.
ReadBack from_triples(const std::string& zone, const std::vector<std::string>& from,
                      const std::vector<std::string>& to, const std::vector<double>& f) {
    ReadBack r;
    r.zone = zone;
    for (std::size_t k = 0; k < from.size(); ++k) {
        if (std::find(r.names.begin(), r.names.end(), from[k]) == r.names.end())
            r.names.push_back(from[k]);
        CHECK(r.F.emplace(std::make_pair(from[k], to[k]), f[k]).second);
    }
    CHECK(r.F.size() == r.names.size() * r.names.size());
    return r;
}

ReadBack read_idf(const std::string& path) {
    const auto objects = detail::parse_idf(read_text(path), path);
    REQUIRE(objects.size() == 1);
    const auto& o = objects.front();
    CHECK(o.type_as_written == "ZoneProperty:UserViewFactors:BySurfaceName");
    REQUIRE((o.fields.size() - 1) % 3 == 0);
    std::vector<std::string> from, to;
    std::vector<double> f;
    for (std::size_t k = 1; k < o.fields.size(); k += 3) {
        from.push_back(o.fields[k].value);
        to.push_back(o.fields[k + 1].value);
        f.push_back(std::stod(o.fields[k + 2].value));
    }
    return from_triples(o.fields[0].value, from, to, f);
}

ReadBack read_epjson(const std::string& path) {
    const auto doc = nlohmann::json::parse(read_text(path));
    const auto& objects = doc.at("ZoneProperty:UserViewFactors:BySurfaceName");
    REQUIRE(objects.size() == 1);
    const auto& o = objects.begin().value();
    std::vector<std::string> from, to;
    std::vector<double> f;
    for (const auto& e : o.at("view_factors")) {
        from.push_back(e.at("from_surface").get<std::string>());
        to.push_back(e.at("to_surface").get<std::string>());
        f.push_back(e.at("view_factor").get<double>());
    }
    return from_triples(o.at("zone_or_zonelist_or_space_or_spacelist_name").get<std::string>(),
                        from, to, f);
}

// Names as the input's surfaces, rows summing to 1 and A_i F_ij = A_j F_ji (the analytic
// method's entries are exact to ~1e-10 at its default tolerance).
void check_zone(const ReadBack& r, const Scene& scene) {
    CHECK(r.zone == "ZONE ONE");
    REQUIRE(r.names.size() == scene.surfaces.size());
    std::map<std::string, double> area;
    for (std::size_t k = 0; k < r.names.size(); ++k) {
        CHECK(r.names[k] == scene.surfaces[k].name);
        area[r.names[k]] = surface_area(scene.surfaces[k]);
    }
    for (const std::string& i : r.names) {
        double sum = 0.0;
        for (const std::string& j : r.names) {
            sum += r.F.at({i, j});
            const double a = area[i] * r.F.at({i, j}), b = area[j] * r.F.at({j, i});
            CHECK(std::abs(a - b) <= 1e-8 * std::max(area[i], area[j]));
        }
        CHECK(std::abs(sum - 1.0) < 1e-8);
    }
}

}  // namespace

TEST_CASE("energyplus output: view factors by surface name read back from .idf and .epJSON") {
    Cli cli;
    const std::string model =
        std::string(FF_TEST_DATA_DIR) + "/energyplus/1ZoneUncontrolled_win_1.idf";
    const Scene scene = load_scene(model);
    for (const char* out : {"vf.idf", "vf.epJSON"}) {
        CAPTURE(out);
        const CliResult r = cli.run("compute " + shell_quote(model) + " --subdivide 3 -o " + out);
        INFO(r.err);
        REQUIRE(r.code == 0);
        const ReadBack back =
            std::string(out) == "vf.idf" ? read_idf(cli.file(out)) : read_epjson(cli.file(out));
        check_zone(back, scene);
    }
    // The same numbers in both files.
    const ReadBack a = read_idf(cli.file("vf.idf")), b = read_epjson(cli.file("vf.epJSON"));
    CHECK(a.F == b.F);
}

TEST_CASE("energyplus output: names IDF cannot carry and per-patch rows are refused") {
    std::ostringstream out;
    CHECK_THROWS_WITH_AS(write_energyplus_view_factors(out, EnergyPlusSyntax::Idf, "Z", {"a,b"},
                                                       DenseMatrix::Zero(1, 1)),
                         doctest::Contains("the name 'a,b' holds a character IDF cannot carry"),
                         Error);
    Cli cli;
    const CliResult r = cli.run("compute cube -o vf.idf --per-patch");
    CHECK(r.err ==
          "formfactor: --per-patch: EnergyPlus view factors are per surface (-o .idf or "
          ".epJSON)\n");
    CHECK(cli.dir().entries() == 0);
}

// EnergyPlus's example zone twice: the second the same room under other names (`second_zone`,
// surfaces Zn002:...), at the same place (each zone is its own enclosure).
std::string two_zone_model(const std::string& second_zone = "ZONE TWO") {
    const std::string model =
        read_text(std::string(FF_TEST_DATA_DIR) + "/energyplus/1ZoneUncontrolled_win_1.idf");
    std::string second = model.substr(model.find("  Zone,"));
    second = second.substr(0, second.find("  GlobalGeometryRules,")) +
             second.substr(second.find("  BuildingSurface:Detailed,"));
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"ZONE ONE", second_zone}, {"Zn001", "Zn002"}})
        for (std::size_t at = 0; (at = second.find(from, at)) != std::string::npos; at += to.size())
            second.replace(at, from.size(), to);
    return model + second;
}

TEST_CASE("energyplus output: --all-zones writes one object per zone, each closed") {
    Cli cli;
    cli.write("two.idf", two_zone_model());
    CliResult r = cli.run("compute two.idf -o vf.idf");
    CHECK(r.err ==
          "formfactor: --zone: two.idf has 2 zones (ZONE ONE, ZONE TWO): choose one with --zone "
          "NAME, or compute each with --all-zones\n");
    r = cli.run("compute two.idf --all-zones --subdivide 2 -o vf.idf");
    INFO(r.err);
    REQUIRE(r.code == 0);
    r = cli.run("compute two.idf --all-zones --subdivide 2 -o vf.epJSON");
    REQUIRE(r.code == 0);
    const auto objects = detail::parse_idf(read_text(cli.file("vf.idf")), "vf.idf");
    REQUIRE(objects.size() == 2);
    const auto doc = nlohmann::json::parse(read_text(cli.file("vf.epJSON")));
    REQUIRE(doc.at("ZoneProperty:UserViewFactors:BySurfaceName").size() == 2);
    for (std::size_t z = 0; z < 2; ++z) {
        const std::string zone = z == 0 ? "ZONE ONE" : "ZONE TWO";
        CAPTURE(zone);
        const auto& o = objects[z];
        CHECK(o.fields[0].value == zone);
        REQUIRE(o.fields.size() == 1 + 3 * 49);
        std::map<std::string, double> sums;
        for (std::size_t k = 1; k < o.fields.size(); k += 3)
            sums[o.fields[k].value] += std::stod(o.fields[k + 2].value);
        CHECK(sums.size() == 7);
        for (const auto& [name, sum] : sums) {
            CHECK(name.rfind(z == 0 ? "Zn001:" : "Zn002:", 0) == 0);
            CHECK(std::abs(sum - 1.0) < 1e-8);
        }
        const auto& j =
            doc.at("ZoneProperty:UserViewFactors:BySurfaceName").at(zone + " view factors");
        CHECK(j.at("zone_or_zonelist_or_space_or_spacelist_name") == zone);
        CHECK(j.at("view_factors").size() == 49);
    }
    r = cli.run("compute two.idf --all-zones -o " + shell_quote("vf_{zone}.idf"));
    CHECK(r.err ==
          "formfactor: -o: an EnergyPlus file holds every zone (one object per zone): its name "
          "takes no {zone}\n");
    r = cli.run("compute two.idf --all-zones -o vf.idf --patches p.csv");
    CHECK(r.err ==
          "formfactor: --all-zones: with -o .idf or .epJSON writes one file; --report, "
          "--patches, --pairs and --stderr go with a matrix file per zone (-o F.npy) or one zone "
          "(--zone NAME)\n");
}

TEST_CASE(
    "energyplus output: --all-zones with a matrix -o writes a file per zone, as --zone does") {
    Cli cli;
    cli.write("two.idf", two_zone_model());
    CliResult r = cli.run(
        "compute two.idf --all-zones --subdivide 2 -o F.npy --patches P.csv --report R.json "
        "--pairs pairs.csv");
    INFO(r.out, r.err);
    REQUIRE(r.code == 0);
    CHECK(r.out.find("zone       ZONE ONE\n") != std::string::npos);
    CHECK(r.out.find("wrote      8 files for 2 zones\n") != std::string::npos);
    CHECK(cli.dir().entries() == 1 + 8);
    for (const std::string zone : {"ZONE ONE", "ZONE TWO"}) {
        CAPTURE(zone);
        const std::string part = zone == "ZONE ONE" ? "ZONE_ONE" : "ZONE_TWO";
        // Each zone's file is what --zone writes for it.
        r = cli.run("compute two.idf --zone " + shell_quote(zone) +
                    " --subdivide 2 -o one.npy --patches one.csv --pairs one_pairs.csv");
        REQUIRE(r.code == 0);
        CHECK(read_text(cli.file("F_" + part + ".npy")) == read_text(cli.file("one.npy")));
        CHECK(read_text(cli.file("P_" + part + ".csv")) == read_text(cli.file("one.csv")));
        CHECK(read_text(cli.file("pairs_" + part + ".csv")) ==
              read_text(cli.file("one_pairs.csv")));
        const auto report = nlohmann::json::parse(read_text(cli.file("R_" + part + ".json")));
        CHECK(report.at("scene").dump().find(zone) != std::string::npos);
        const DenseMatrix F = read_matrix(cli.file("F_" + part + ".npy"));
        REQUIRE(F.rows() > 7);  // patches: each surface split 2 x 2
        check_row_sums(F, 1.0, 1e-9);
    }

    // {zone} in a name: the zone's name goes there; sparse and ParaView outputs too.
    r = cli.run("compute two.idf --all-zones -o " + shell_quote("{zone}-F.mtx"));
    REQUIRE(r.code == 0);
    CHECK(read_sparse_matrix(cli.file("ZONE_TWO-F.mtx")).n == 10);  // the holed wall: 4 patches
    r = cli.run("compute two.idf --all-zones --subdivide 2 -o room.vtu");
    REQUIRE(r.code == 0);
    CHECK(read_text(cli.file("room_ZONE_ONE.vtu")).find("NumberOfCells=\"") != std::string::npos);
}

TEST_CASE("energyplus output: --all-zones writes no file when a zone fails or two share a name") {
    Cli cli;
    // The second zone holds a window beside its wall, which its build refuses: after the first
    // zone was computed.
    std::string model = two_zone_model();
    model +=
        "  Wall:Exterior, Extra wall, EXTWALL80, ZONE TWO, 0, 90, 0, 0, 0, 3, 2;\n"
        "  Window, Stray window, SINGLE PANE HW WINDOW, Extra wall, , 1, 40, 1, 1, 1;\n";
    cli.write("two.idf", model);
    CliResult r = cli.run("compute two.idf --all-zones -o F.csv --report R.json");
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK(r.err.find("Window 'Stray window' is not within its base surface") != std::string::npos);
    CHECK(r.out.find("zone       ZONE ONE\n") != std::string::npos);  // computed, not written
    CHECK(cli.dir().entries() == 1);

    // "ZONE ONE" and "ZONE/ONE" give one file name.
    cli.write("clash.idf", two_zone_model("ZONE/ONE"));
    r = cli.run("compute clash.idf --all-zones -o F.csv");
    CHECK(r.err ==
          "formfactor: --all-zones: zones 'ZONE ONE' and 'ZONE/ONE' would both write "
          "'F_ZONE_ONE.csv'; put {zone} where the name goes or compute them one by one with "
          "--zone\n");
    CHECK(cli.dir().entries() == 2);

    r = cli.run("compute cornell --all-zones -o F.csv");
    CHECK(r.err ==
          "formfactor: --all-zones: computes the zones of an EnergyPlus model (.idf or .epJSON); "
          "'cornell' is not one\n");
}

TEST_CASE("energyplus output: solve --all-zones solves each zone as solve --zone does") {
    Cli cli;
    cli.write("two.idf", two_zone_model());
    // Per-zone inputs by the same naming rule: a hot floor in each zone.
    for (const std::string part : {"ZONE_ONE", "ZONE_TWO"}) {
        const std::string floor = part == "ZONE_ONE" ? "Zn001:Flr001" : "Zn002:Flr001";
        cli.write("T_" + part + ".csv", "surface,emissivity,temperature\n" + floor + ",0.9,350\n");
    }
    CliResult r = cli.run("compute two.idf --all-zones -o F.npy");
    REQUIRE(r.code == 0);
    r = cli.run(
        "solve two.idf --all-zones --thermal --properties T.csv --matrix F.npy -o "
        "J.csv --report R.json");
    INFO(r.out, r.err);
    REQUIRE(r.code == 0);
    CHECK(r.out.find("wrote      4 files for 2 zones\n") != std::string::npos);
    for (const std::string zone : {"ZONE ONE", "ZONE TWO"}) {
        CAPTURE(zone);
        const std::string part = zone == "ZONE ONE" ? "ZONE_ONE" : "ZONE_TWO";
        r = cli.run("solve two.idf --zone " + shell_quote(zone) + " --thermal --properties T_" +
                    part + ".csv -o one.csv");
        REQUIRE(r.code == 0);
        const std::string mine = read_text(cli.file("J_" + part + ".csv"));
        CHECK(mine == read_text(cli.file("one.csv")));
        CHECK(mine.find("350") != std::string::npos);  // the hot floor's temperature
        const auto report = nlohmann::json::parse(read_text(cli.file("R_" + part + ".json")));
        CHECK(report.at("options").at("matrix") == "F_" + part + ".npy");
    }
    // A zone that fails (its properties name a surface of the other zone): nothing written.
    Cli bad;
    bad.write("two.idf", two_zone_model());
    bad.write("T_ZONE_ONE.csv", "surface,emissivity,temperature\nZn001:Flr001,0.9,350\n");
    bad.write("T_ZONE_TWO.csv", "surface,emissivity,temperature\nZn001:Flr001,0.9,350\n");
    r = bad.run("solve two.idf --all-zones --thermal --properties T.csv -o J.csv");
    CHECK(r.code == 1);
    // Zone one's warning (adiabatic patches), then the one error.
    const std::string error = "formfactor: T_ZONE_TWO.csv:2: unknown surface 'Zn001:Flr001'\n";
    CHECK(r.err.size() > error.size());
    CHECK(r.err.compare(r.err.size() - error.size(), error.size(), error) == 0);
    CHECK(bad.dir().entries() == 3);
    r = bad.run("solve cornell --all-zones -o J.csv");
    CHECK(r.err ==
          "formfactor: --all-zones: solves the zones of an EnergyPlus model (.idf or .epJSON); "
          "'cornell' is not one\n");
}

TEST_CASE("energyplus output: view --all-zones writes a page per zone or none") {
    Cli cli;
    cli.write("two.idf", two_zone_model());
    CliResult r = cli.run("view two.idf --all-zones -o {zone}.html");
    INFO(r.out, r.err);
    REQUIRE(r.code == 0);
    CHECK(r.out.find("wrote      2 files for 2 zones\n") != std::string::npos);
    for (const std::string part : {"ZONE_ONE", "ZONE_TWO"}) {
        const std::string page = read_text(cli.file(part + ".html"));
        CHECK(page.find(part == "ZONE_ONE" ? "Zn001:Wall001" : "Zn002:Wall001") !=
              std::string::npos);
    }
    // Every page read from its own matrix file; a missing one fails the run before any page.
    Cli bad;
    bad.write("two.idf", two_zone_model());
    r = bad.run("compute two.idf --zone 'ZONE ONE' -o F_ZONE_ONE.npy");
    REQUIRE(r.code == 0);
    r = bad.run("view two.idf --all-zones --matrix F.npy -o page.html");
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK(r.err.find("F_ZONE_TWO.npy") != std::string::npos);
    CHECK(bad.dir().entries() == 2);
}
