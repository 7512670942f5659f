// The command line on awkward inputs: `point` with obstructions and many points, scenes
// too large for the machine, empty and one-patch scenes, and the reciprocity report.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/scene/points.h"
#include "support/cli_runner.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::read_text;

namespace {

std::string describe(const CliResult& r) {
    return "exit " + std::to_string(r.code) + "\nstdout: " + r.out + "\nstderr: " + r.err;
}

// The unit square [0, 1]² at z = 1 facing down, and an obstruction square [0.25, 0.75]² at
// z = 5/6: seen from (0.5, 0.5, 0) its shadow is the centred square of half-width 0.3.
const char* kShadowObj =
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\n"
    "v 0.25 0.25 0.83333333333333337\nv 0.75 0.25 0.83333333333333337\n"
    "v 0.75 0.75 0.83333333333333337\nv 0.25 0.75 0.83333333333333337\n"
    "g ceiling\nf 1 2 3 4\n"
    "g obstruction_panel\nf 5 6 7 8\n";
constexpr double kRing = 0.1370846812475841;           // F(0.5) − F(0.3), closed form
constexpr double kUnobstructed = 0.23945647046077354;  // F(0.5)

// A matrix file that need not be square.
DenseMatrix read_any(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (path.size() > 4 && path.substr(path.size() - 4) == ".npy") return read_npy_matrix(in, path);
    return read_csv_matrix(in, path);
}

double first_value(const std::string& out) {
    return std::stod(out.substr(std::string("patch,F\n0,").size()));
}

}  // namespace

TEST_CASE("cli inputs: point is exact with obstructions") {
    Cli cli;
    cli.write("shadow.obj", kShadowObj);
    CliResult r = cli.run("point shadow.obj --at 0.5 0.5 0 --normal 0 0 1");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    REQUIRE(r.out.rfind("patch,F\n0,", 0) == 0);
    CHECK(std::abs(first_value(r.out) - kRing) < 1e-13);
    CHECK(r.out.find("\n1,") == std::string::npos);  // the obstruction has no column
    // Without the obstruction group the panel is a surface: it blocks too, and has a column.
    std::string plain = kShadowObj;
    plain.replace(plain.find("obstruction_panel"), 17, "panel");
    cli.write("plain.obj", plain);
    r = cli.run("point plain.obj --at 0.5 0.5 0 --normal 0 0 1");
    REQUIRE(r.code == 0);
    CHECK(std::abs(first_value(r.out) - kRing) < 1e-13);
    CHECK(r.out.find("\n1,") != std::string::npos);
    // The ceiling alone: the unobstructed value.
    cli.write("ceiling.obj", "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf 1 2 3 4\n");
    r = cli.run("point ceiling.obj --at 0.5 0.5 0 --normal 0 0 1");
    REQUIRE(r.code == 0);
    CHECK(std::abs(first_value(r.out) - kUnobstructed) < 1e-14);
}

TEST_CASE("cli inputs: point --points gives the M×N matrix as CSV or NPY") {
    Cli cli;
    cli.write("shadow.obj", kShadowObj);
    cli.write("sensors.csv",
              "x,y,z,nx,ny,nz\n"
              "# under the panel, facing up\n"
              "0.5, 0.5, 0, 0, 0, 1\n"
              "\n"
              "0.5 0.5 0 0 0 -1   # facing away\n"
              "0.5,0.5,0,0,0,9  # normalised\n");
    CliResult r = cli.run("point shadow.obj --points sensors.csv -o F.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("points     3 from sensors.csv") != std::string::npos);
    CHECK(r.out.find("(3×1: row = point, column = patch)") != std::string::npos);
    const DenseMatrix F = read_any(cli.file("F.csv"));
    REQUIRE(F.rows() == 3);
    REQUIRE(F.cols() == 1);
    CHECK(std::abs(F(0, 0) - kRing) < 1e-13);
    CHECK(F(1, 0) == 0.0);
    CHECK(F(2, 0) == F(0, 0));
    r = cli.run("point shadow.obj --points sensors.csv -o F.npy");
    REQUIRE(r.code == 0);
    const DenseMatrix N = read_any(cli.file("F.npy"));
    CHECK((N - F).cwiseAbs().maxCoeff() == 0.0);
    // Standard output without -o: the matrix as CSV.
    r = cli.run("point shadow.obj --points sensors.csv");
    REQUIRE(r.code == 0);
    CHECK(r.out.find(',') == std::string::npos);  // one column
    CHECK(std::count(r.out.begin(), r.out.end(), '\n') == 3);
    // A built-in scene with several patches: one column per patch.
    cli.write("one.csv", "0.5 0.5 0.5 0 0 1\n");
    r = cli.run("point cube --subdivide 2 --points one.csv -o C.csv");
    REQUIRE(r.code == 0);
    const DenseMatrix C = read_any(cli.file("C.csv"));
    REQUIRE(C.cols() == 24);
    CHECK(std::abs(C.sum() - 1.0) < 1e-13);  // inside the closed cube
}

TEST_CASE("cli inputs: bad point files and option mixes give one clear line") {
    Cli cli;
    cli.write("five.csv", "x,y,z,nx,ny,nz\n0,0,0,0,0,1\n1,2,3,4,5\n");
    cli.write("word.csv", "0,0,0,0,0,1\n0,0,abc,0,0,1\n");
    cli.write("zero.csv", "# sensors\n0,0,0,0,0,0\n");
    cli.write("empty.csv", "x,y,z,nx,ny,nz\n# nothing\n");
    cli.write("inf.csv", "0,0,inf,0,0,1\n");
    cli.write("gap.csv", "0,0,,0,0,1\n");
    const struct {
        const char* args;
        int code;
        const char* message;
    } cases[] = {
        {"point plates --points five.csv", 1, "five.csv:3: line has 5 fields (x,y,z,nx,ny,nz"},
        {"point plates --points word.csv", 1, "word.csv:2: malformed number 'abc' (z)"},
        {"point plates --points zero.csv", 1, "zero.csv:2: the normal (nx, ny, nz) must not be"},
        {"point plates --points empty.csv", 1, "empty.csv: no points"},
        {"point plates --points inf.csv", 1, "inf.csv:1: z = 'inf' is not finite"},
        {"point plates --points gap.csv", 1, "gap.csv:1: empty field z"},
        {"point plates --points missing.csv", 1, "missing.csv: cannot open file"},
        {"point plates --points five.csv --at 0 0 0", 2, "--at: cannot be combined with --points"},
        {"point plates --points five.csv --normal 0 0 1", 2, "--normal: cannot be combined"},
        {"point plates --at 0 0 0", 2, "--normal: is required with --at"},
        {"point plates", 2, "--at: is required (or --points FILE.csv)"},
        {"point plates --points word.csv -o F.txt", 2, "-o: use .csv or .npy"},
    };
    for (const auto& c : cases) {
        const CliResult r = cli.run(c.args);
        INFO(c.args, describe(r));
        CHECK(r.code == c.code);
        CHECK(r.one_error_line());
        CHECK(r.err.find(c.message) != std::string::npos);
        CHECK(r.out.empty());
    }
}

TEST_CASE("cli inputs: a run larger than the machine is refused before allocating") {
    Cli cli;
    // 6 × 2000² = 24 million patches: F alone would be 4.6 PB. Refused before subdividing.
    for (const char* args :
         {"compute cube --subdivide 2000 -o F.npy",
          "compute cube --subdivide 2000 -o F.npy --method mc-area",
          "solve cube --subdivide 2000 -o B.csv", "run cube --subdivide 2000 --out-dir out"}) {
        const CliResult r = cli.run(args);
        INFO(args, describe(r));
        CHECK(r.code == 1);
        CHECK(r.one_error_line());
        CHECK(r.err.find("formfactor: not enough memory: 24,000,000 patches need about") == 0);
        // solve's --storage auto takes the hierarchical operator for so large a closed cube: no
        // F then, but the patches alone do not fit.
        if (std::string(args).rfind("solve", 0) == 0)
            CHECK(r.err.find("patches and per-patch tables 197 GB") != std::string::npos);
        else
            CHECK(r.err.find("F (24,000,000² doubles) 4.6 PB") != std::string::npos);
        CHECK(r.err.find("available; at most about ") != std::string::npos);
        CHECK(r.err.find("use a coarser --subdivide or a larger --max-edge (without either, one "
                         "patch per surface: N = 6)") != std::string::npos);
        CHECK(r.err.find("bad_alloc") == std::string::npos);
        CHECK(cli.dir().entries() == 0);
    }
    CliResult r = cli.run("compute cube --subdivide 2000 -o F.npy --method mc-area");
    CHECK(r.err.find("standard errors (24,000,000² doubles) 4.6 PB") != std::string::npos);
    r = cli.run("solve cube --subdivide 2000 -o B.csv --solver direct --exchange-factors X.npy");
    CHECK(r.err.find("direct solve: LU factors") != std::string::npos);
    CHECK(r.err.find("exchange factors: result") != std::string::npos);
    // Points: M × N.
    cli.write("one.csv", "0.5 0.5 0.5 0 0 1\n");
    r = cli.run("point cube --max-edge 0.00001 --points one.csv");
    CHECK(r.code == 1);
    CHECK(r.err.find("not enough memory") != std::string::npos);
}

TEST_CASE("cli inputs: empty scenes are input errors, one patch is a warning") {
    Cli cli;
    cli.write("empty.obj", "# nothing but vertices\nv 0 0 0\nv 1 0 0\nv 1 1 0\n");
    cli.write("blockers.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\ng obstruction\nf 1 2 3\n");
    cli.write("empty.vs3", "T empty\nF 3\nV 1 0 0 0\nEnd of data\n");
    cli.write("blockers.vs3",
              "T blockers\nF 3\nV 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nO 1 1 2 3 0 0 0 0 b\n"
              "End of data\n");
    const struct {
        const char* args;
        const char* message;
    } cases[] = {
        {"compute empty.obj -o F.csv",
         "formfactor: empty.obj: the scene is empty: no faces (f records), nothing to compute"},
        {"compute blockers.obj -o F.csv",
         "formfactor: blockers.obj: all 1 surfaces are obstructions: there are no surfaces to "
         "compute form factors between"},
        {"info empty.vs3", "formfactor: empty.vs3: the scene is empty: no surfaces (S records)"},
        {"solve blockers.vs3 -o B.csv",
         "formfactor: blockers.vs3: all 1 surfaces are obstructions"},
        {"point empty.obj --at 0 0 1 --normal 0 0 -1", "formfactor: empty.obj: the scene is empty"},
    };
    for (const auto& c : cases) {
        const CliResult r = cli.run(c.args);
        INFO(c.args, describe(r));
        CHECK(r.code == 1);
        CHECK(r.one_error_line());
        CHECK(r.err.rfind(c.message, 0) == 0);
    }
    CHECK(cli.dir().entries() == 4);  // the inputs only

    cli.write("one.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    CliResult r = cli.run("compute one.obj -o F.csv --report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.err ==
          "formfactor: warning: the scene has one patch: F is the 1×1 matrix [0] (a planar patch "
          "does not see itself; there is nothing to exchange with)\n");
    CHECK(read_text(cli.file("F.csv")) == "0\n");
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["scene"]["warnings"][0].get<std::string>().find("one patch") != std::string::npos);
    // Subdivided, it has four patches: no warning.
    r = cli.run("compute one.obj --subdivide 2 -o F.csv");
    CHECK(r.code == 0);
    CHECK(r.err.empty());
    // A point sees the one patch: no warning either.
    r = cli.run("point one.obj --at 0.5 0.2 1 --normal 0 0 -1");
    CHECK(r.code == 0);
    CHECK(r.err.empty());
}

TEST_CASE("cli inputs: reciprocity is reported as measures and a verdict, not one ratio") {
    Cli cli;
    CliResult r = cli.run("compute cube --subdivide 2 -o F.csv --report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("reciprocity area-weighted ") != std::string::npos);
    CHECK(r.out.find(": within what analytic promises (row-relative defect") != std::string::npos);
    auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    auto rec = report["diagnostics"]["reciprocity"];
    CHECK(rec["verdict"]["within"] == true);
    CHECK(rec["verdict"]["promise"] == "exact");
    CHECK(rec["area_weighted"].get<double>() < 1e-12);
    CHECK(rec["z"].is_null());

    // Monte Carlo: z-scores, consistent with chance; the worst pair is a detail line.
    r = cli.run(
        "compute cornell-empty --subdivide 3 --method mc-hemisphere --samples 4000 -o "
        "M.npy --report m.json");
    REQUIRE(r.code == 0);
    CHECK(r.out.find("z max ") != std::string::npos);
    CHECK(r.out.find(": consistent with chance (max |z| ") != std::string::npos);
    CHECK(r.out.find("            worst pair (") != std::string::npos);
    CHECK(r.out.find("reciprocity max |A_i F_ij") == std::string::npos);
    report = nlohmann::json::parse(read_text(cli.file("m.json")));
    rec = report["diagnostics"]["reciprocity"];
    CHECK(rec["verdict"]["promise"] == "statistical");
    CHECK(rec["verdict"]["within"] == true);
    CHECK(rec["z"]["pairs"].get<int>() > 100);
    CHECK(rec["z"]["rms"].get<double>() < rec["verdict"]["z_rms_limit"].get<double>());
    CHECK(rec.contains("max_defect"));  // kept: the worst pair

    // Hemicube: no promise, words only; solve prints the line too.
    r = cli.run("compute plates --method hemicube --resolution 64 -o H.csv");
    REQUIRE(r.code == 0);
    CHECK(r.out.find("hemicube makes no reciprocity promise") != std::string::npos);
    r = cli.run("solve plates -o B.csv --matrix H.csv");
    REQUIRE(r.code == 0);
    CHECK(r.out.find("reciprocity area-weighted") != std::string::npos);
    CHECK(r.out.find("no promise to compare with") != std::string::npos);
}

TEST_CASE("cli inputs: the point file reader, line by line") {
    std::istringstream in(
        "# sensors\r\nX, Y, Z, NX, NY, NZ\r\n1,2,3, 0,0,1e-200\n\n4 5 6 3 0 4 # spaces\n");
    const PointElements p = parse_points_csv(in, "p.csv");
    REQUIRE(p.positions.size() == 2u);
    CHECK(p.positions[0] == Vec3(1, 2, 3));
    CHECK(p.normals[0] == Vec3(0, 0, 1));
    CHECK(p.lines[0] == 3);
    CHECK(p.positions[1] == Vec3(4, 5, 6));
    CHECK((p.normals[1] - Vec3(0.6, 0, 0.8)).norm() < 1e-16);
    CHECK(p.lines[1] == 5);
    // A header only counts as the first line with content.
    std::istringstream late("1,2,3,0,0,1\nx,y,z,nx,ny,nz\n");
    CHECK_THROWS_WITH_AS(parse_points_csv(late, "late.csv"), "late.csv:2: malformed number 'x' (x)",
                         InputError);
}
