// End-to-end tests of the `formfactor` command line: the binary is run as a user would run it.

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "formfactor/output/matrix_io.h"
#include "support/cli_runner.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::read_text;

namespace {

// Reference values (Howell's catalog, copied from shared/reference/catalog.json).
constexpr double kC11PlatesF12 = 0.19982489569838746;         // C-11, a = b = c = 1
constexpr double kC14PerpendicularF12 = 0.20004377607540316;  // C-14, l = w = h = 1
constexpr double kB3CornerF = 0.13853160599489298;            // B-3, a = b = c = 1
// The analytic method is exact to ~1e-12 (its error model); 1e-10 leaves room for the CSV.
constexpr double kExactTol = 1e-10;

std::string describe(const CliResult& r) {
    return "exit " + std::to_string(r.code) + "\nstdout: " + r.out + "\nstderr: " + r.err;
}

// The two plates of C-11 as an OBJ file (bottom faces +z, top faces -z).
const char* kPlatesObj =
    "# two parallel unit squares\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "v 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\n"
    "g bottom\nf 1 2 3 4\n"
    "g top\nf 5 6 7 8\n";

}  // namespace

TEST_CASE("cli: --version and --help on every subcommand") {
    Cli cli;
    CliResult r = cli.run("--version");
    CHECK(r.code == 0);
    CHECK(r.out.rfind("formfactor " FF_VERSION "\n", 0) == 0);
    CHECK(r.out.find("Licence: MIT") != std::string::npos);
    for (const char* sub : {"", "compute ", "point ", "info ", "run ", "solve ", "render "}) {
        r = cli.run(std::string(sub) + "--help");
        INFO(sub, describe(r));
        CHECK(r.code == 0);
        CHECK(r.out.find("Usage:") != std::string::npos);
        CHECK(r.err.empty());
    }
    r = cli.run("compute --help");
    CHECK(r.out.find("--subdivide") != std::string::npos);
    CHECK(r.out.find("--report") != std::string::npos);
    CHECK(cli.dir().entries() == 0);
}

TEST_CASE("cli: compute on plates gives Howell C-11, with a report") {
    Cli cli;
    const CliResult r = cli.run("compute plates -o F.csv --report report.json --patches p.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("N = 2") != std::string::npos);
    CHECK(r.out.find("analytic") != std::string::npos);
    CHECK(r.out.find("F.csv") != std::string::npos);
    const DenseMatrix F = read_matrix(cli.file("F.csv"));
    REQUIRE(F.rows() == 2);
    CHECK(std::abs(F(0, 1) - kC11PlatesF12) < kExactTol);
    CHECK(std::abs(F(1, 0) - kC11PlatesF12) < kExactTol);
    CHECK(F(0, 0) == 0.0);

    const auto report = nlohmann::json::parse(read_text(cli.file("report.json")));
    CHECK(report["N"] == 2);
    CHECK(report["method"] == "analytic");
    CHECK(report["command"] == "compute");
    CHECK(report["scene"]["name"] == "plates");
    CHECK(report["options"]["output"] == "F.csv");
    CHECK(report["options"]["subdivide"] == 1);
    CHECK(report["threads"].get<int>() >= 1);
    CHECK(report["timings"]["total"].get<double>() >= report["timings"]["compute"].get<double>());
    CHECK(std::abs(report["diagnostics"]["row_sum"]["max"].get<double>() - kC11PlatesF12) <
          kExactTol);
    CHECK(report["diagnostics"]["reciprocity"]["max_defect"].get<double>() < 1e-12);
    CHECK(report["diagnostics"]["negative_entries"] == 0);
    CHECK(report["details"].is_object());
    CHECK(read_text(cli.file("p.csv")).rfind("patch,surface,surface_name,", 0) == 0);
    CHECK(cli.dir().entries() == 3);
}

TEST_CASE("cli: compute on perpendicular gives Howell C-14, OBJ input and subdivision add up") {
    Cli cli;
    CliResult r = cli.run("compute perpendicular -o F.npy");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const DenseMatrix F = read_matrix(cli.file("F.npy"));
    REQUIRE(F.rows() == 2);
    CHECK(std::abs(F(0, 1) - kC14PerpendicularF12) < kExactTol);
    CHECK(std::abs(F(1, 0) - kC14PerpendicularF12) < kExactTol);

    // The same plates from an OBJ file, split 3×3: the 9×9 blocks sum back to C-11.
    cli.write("plates.obj", kPlatesObj);
    r = cli.run("compute plates.obj --subdivide 3 -o G.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const DenseMatrix G = read_matrix(cli.file("G.csv"));
    REQUIRE(G.rows() == 18);
    // F_{bottom→top} = Σ_i (A_i/A) Σ_j F_ij over the children; all children have equal area.
    CHECK(std::abs(G.block(0, 9, 9, 9).sum() / 9.0 - kC11PlatesF12) < kExactTol);
}

TEST_CASE("cli: compute on cube: every row sums to 1, View3D .txt output") {
    Cli cli;
    CliResult r = cli.run("compute cube --subdivide 2 -o F.txt --report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    std::istringstream in(read_text(cli.file("F.txt")));
    const View3dFile f = read_view3d_text(in, "F.txt");
    CHECK(f.program == "View3D");
    CHECK(f.version == "3.2");
    CHECK(f.format == 0);
    CHECK(f.encl == 1);  // the built-in cube is an enclosure
    CHECK(f.didemit == 0);
    REQUIRE(f.F.rows() == 24);
    for (Eigen::Index i = 0; i < 24; ++i) CHECK(std::abs(f.F.row(i).sum() - 1.0) < 24 * 5e-7);

    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(std::abs(report["diagnostics"]["row_sum"]["min"].get<double>() - 1.0) < 1e-9);
    CHECK(std::abs(report["diagnostics"]["row_sum"]["max"].get<double>() - 1.0) < 1e-9);
    CHECK(report["scene"]["enclosure"] == true);
}

TEST_CASE("cli: a cube whose faces point outwards computes zero rows with a warning") {
    // The unit cube as a CAD tool writes a solid: every face's front outwards.
    constexpr const char* kOutwardCube =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    constexpr const char* kInwardCube =
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        "f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";
    Cli cli;
    cli.write("out.obj", kOutwardCube);
    cli.write("in.obj", kInwardCube);
    for (const std::string out : {"F.npy", "F.mtx"}) {
        CAPTURE(out);
        CliResult r = cli.run("compute out.obj -o " + out);
        INFO(describe(r));
        CHECK(r.code == 0);
        CHECK(r.err.find("no patch sees any other") != std::string::npos);
        r = cli.run("compute in.obj -o G" + out);
        CHECK(r.code == 0);
        CHECK(r.err.find("no patch sees any other") == std::string::npos);
    }
}

TEST_CASE("cli: point gives Howell B-3 for a square with the normal through a corner") {
    Cli cli;
    // 1×1 square at height 1, facing down (CCW seen from below), corner above the origin.
    cli.write("square.obj", "v 0 1 1\nv 1 1 1\nv 1 0 1\nv 0 0 1\nf 1 2 3 4\n");
    CliResult r = cli.run("point square.obj --at 0 0 0 --normal 0 0 1");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    REQUIRE(r.out.rfind("patch,F\n0,", 0) == 0);
    const double F = std::stod(r.out.substr(std::string("patch,F\n0,").size()));
    CHECK(std::abs(F - kB3CornerF) < kExactTol);

    // A non-unit normal is normalised; -o writes the same CSV.
    r = cli.run("point square.obj --at 0 0 0 --normal 0 0 7 -o dF.csv");
    REQUIRE(r.code == 0);
    const std::string text = read_text(cli.file("dF.csv"));
    CHECK(std::abs(std::stod(text.substr(std::string("patch,F\n0,").size())) - kB3CornerF) <
          kExactTol);
    CHECK(r.out.find("dF.csv") != std::string::npos);

    // Facing away: nothing is seen.
    r = cli.run("point square.obj --at 0 0 0 --normal 0 0 -1");
    REQUIRE(r.code == 0);
    CHECK(std::stod(r.out.substr(std::string("patch,F\n0,").size())) == 0.0);
}

TEST_CASE("cli: info describes a scene, as text and as JSON") {
    Cli cli;
    CliResult r = cli.run("info plates");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("plates") != std::string::npos);
    CHECK(r.out.find("patches      2") != std::string::npos);
    CHECK(r.out.find("bottom") != std::string::npos);
    CHECK(r.out.find("enclosure    no") != std::string::npos);

    r = cli.run("info cube --subdivide 3 --json");
    REQUIRE(r.code == 0);
    const auto j = nlohmann::json::parse(r.out);
    CHECK(j["scene"]["surfaces"] == 6);
    CHECK(j["scene"]["patches"] == 54);
    CHECK(j["scene"]["enclosure"] == true);
    REQUIRE(j["surfaces"].size() == 6);
    CHECK(j["surfaces"][0]["patches"] == 9);
    CHECK(j["materials"].size() >= 1);
    CHECK(cli.dir().entries() == 0);
}

TEST_CASE("cli: run writes the main job into out/" * doctest::test_suite("slow")) {
    Cli cli;
    const CliResult r = cli.run("run");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    for (const char* f :
         {"out/formfactors.npy", "out/patches.csv", "out/report.json", "out/standard_errors.npy",
          "out/radiosity.csv", "out/cornell.png", "out/cornell.ply", "out/cornell.html"}) {
        CHECK(std::filesystem::exists(cli.file(f)));
        CHECK(r.out.find(f) != std::string::npos);
    }
    const auto report = nlohmann::json::parse(read_text(cli.file("out/report.json")));
    CHECK(report["command"] == "run");
    CHECK(report["scene"]["name"] == "cornell");
    // default_method picks analytic (obstruction-aware); run prefers mc-hemisphere
    // (a whole row per set of rays) for its fine subdivision, and says so.
    CHECK(report["method"] == "mc-hemisphere");
    CHECK(r.out.find("note: cornell occludes") != std::string::npos);
    CHECK(report["solve"]["solver"]["converged"] == true);
    CHECK(report["render"]["width"] == 512);
    const std::size_t n = report["N"].get<std::size_t>();
    CHECK(n >= 100);
    const DenseMatrix F = read_matrix(cli.file("out/formfactors.npy"));
    CHECK(static_cast<std::size_t>(F.rows()) == n);
    CHECK(read_matrix(cli.file("out/standard_errors.npy")).rows() == F.rows());
    CHECK(report["diagnostics"]["negative_entries"] == 0);
    CHECK(report["diagnostics"]["standard_error"]["max"].get<double>() > 0.0);
    CHECK(r.out.find("compute") != std::string::npos);  // per-step timings are printed
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(cli.file("out")))
        ++files;
    CHECK(files == 8);  // no temporaries left
}

TEST_CASE("cli: run on an unoccluded scene, into another directory") {
    Cli cli;
    const CliResult r = cli.run("run plates --out-dir res");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const auto report = nlohmann::json::parse(read_text(cli.file("res/report.json")));
    CHECK(report["method"] == "analytic");
    CHECK(report["N"] == 288);  // run's default subdivision, 12x12 per surface
    CHECK(report["diagnostics"]["standard_error"].is_null());
    CHECK_FALSE(std::filesystem::exists(cli.file("res/standard_errors.npy")));
    CHECK(std::abs(read_matrix(cli.file("res/formfactors.npy")).topRightCorner(144, 144).sum() /
                       144.0 -
                   kC11PlatesF12) < kExactTol);
    CHECK(std::filesystem::exists(cli.file("res/plates.png")));
}

TEST_CASE("cli: the default method handles occlusion, standard errors of Monte-Carlo methods") {
    Cli cli;
    // The default is the most accurate method: analytic, obstruction-aware.
    CliResult r = cli.run("compute cornell -o F0.npy --report r0.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const auto report0 = nlohmann::json::parse(read_text(cli.file("r0.json")));
    CHECK(report0["method"] == "analytic");
    CHECK(report0["options"]["method_given"] == false);
    CHECK(report0["details"]["obstructed"] == true);

    r = cli.run("compute cornell --method mc-target -o F.npy --report r.json --stderr se.csv");
    REQUIRE(r.code == 0);
    CHECK(r.out.find("std error") != std::string::npos);
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["method"] == "mc-target");
    CHECK(report["outputs"]["standard_error"] == "se.csv");
    CHECK(read_matrix(cli.file("se.csv")).rows() == 20);
    // Same formats as -o, View3D's text layout included; --stderr is an alias of --standard-error.
    r = cli.run("compute plates --method mc-area --samples 256 -o F2.npy --stderr se2.txt");
    REQUIRE(r.code == 0);
    CHECK(read_matrix(cli.file("se2.txt")).rows() == 2);
    r = cli.run("compute plates --method mc-area --samples 256 -o F3.npy --standard-error se3.npy");
    CHECK(r.code == 0);

    r = cli.run("compute cornell --method hemicube --stderr G.csv -o G.npy");
    CHECK(r.code == 2);  // an exact-per-point method has no standard errors: nothing written
    CHECK(r.one_error_line());
    CHECK_FALSE(std::filesystem::exists(cli.file("G.npy")));

    r = cli.run("compute plates -o G.npy --standard-error se2.npy");
    CHECK(r.code == 2);
    CHECK(r.one_error_line());
    CHECK(r.err.find("--stderr") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(cli.file("G.npy")));
    CHECK_FALSE(std::filesystem::exists(cli.file("se2.npy")));
}

// ---- errors: one line on stderr, an exit code, no output ------------------------------------

namespace {

struct ErrorCase {
    const char* args;      ///< command line
    int code;              ///< expected exit code
    const char* expected;  ///< substring of the error line
};

/// Runs each case in a fresh directory holding `files`; checks one line, code, no new file.
void check_errors(const std::vector<std::pair<std::string, std::string>>& files,
                  const std::vector<ErrorCase>& cases) {
    for (const auto& c : cases) {
        Cli cli;
        for (const auto& [name, text] : files) cli.write(name, text);
        const CliResult r = cli.run(c.args);
        INFO("formfactor ", c.args, "\n", describe(r));
        CHECK(r.code == c.code);
        CHECK(r.one_error_line());
        CHECK(r.err.find(c.expected) != std::string::npos);
        CHECK(r.out.empty());
        CHECK(cli.dir().entries() == files.size());  // nothing written, no temporary left
    }
}

}  // namespace

TEST_CASE("cli: bad options give one line naming the option, exit 2, no output") {
    check_errors({}, {
                         {"compute plates -o F.csv --subdivide 0", 2, "--subdivide"},
                         {"compute plates -o F.csv --subdivide -3", 2, "--subdivide"},
                         {"compute plates -o F.csv --subdivide abc", 2, "--subdivide"},
                         {"compute plates -o F.csv --max-edge 0", 2, "--max-edge"},
                         {"compute plates -o F.csv --max-edge nan", 2, "--max-edge"},
                         {"compute plates -o F.csv --max-edge -1", 2, "--max-edge"},
                         {"compute plates -o F.csv --subdivide 2 --max-edge 0.5", 2,
                          "--subdivide: cannot be combined with --max-edge"},
                         {"compute plates -o F.csv --threads -1", 2, "--threads"},
                         {"compute plates -o F.csv --threads 100000", 2, "--threads"},
                         {"compute plates -o F.csv --tolerance 0", 2, "--tolerance"},
                         {"compute plates -o F.csv --tolerance -1", 2, "--tolerance"},
                         {"compute plates -o F.csv --method nosuch", 2, "--method"},
                         {"compute plates -o F.csv --samples -5", 2, "--samples"},
                         {"compute plates -o F.csv --sampler bogus", 2, "--sampler"},
                         {"compute plates -o F.csv --stderr se.tsv", 2, "--stderr"},
                         {"compute plates", 2, "-o: an output file is required"},
                         {"compute plates -o F.xyz", 2,
                          "-o: unknown output extension '.xyz' (use .csv, .npy, .txt, .dat, .vtu, "
                          ".idf, .epJSON, .mtx or .h5)"},
                         {"compute plates -o F", 2, "-o"},
                         {"compute plates -o F.csv --report F.csv", 2, "--report"},
                         {"compute plates -o F.csv --patches p.txt", 2, "--patches"},
                         {"compute -o F.csv", 2, "SCENE"},
                         {"compute plates -o F.csv --bogus", 2, "--bogus"},
                         {"point plates --at 0 0 0 --normal 0 0 0", 2, "--normal"},
                         {"point plates --at 0 0 0 --normal nan 0 1", 2, "--normal"},
                         {"point plates --at 0 0 inf --normal 0 0 1", 2, "--at"},
                         {"point plates --at 0 0 --normal 0 0 1", 2, "--at"},
                         {"point plates --normal 0 0 1", 2, "--at"},
                         {"point plates --at 0 0 0 --normal 0 0 1 -o F.npy", 2, "-o"},
                         {"info plates --subdivide 0", 2, "--subdivide"},
                         {"run plates --subdivide 0", 2, "--subdivide"},
                         {"run plates --threads -2", 2, "--threads"},
                         {"frobnicate", 2, "unknown subcommand 'frobnicate'"},
                     });
}

TEST_CASE("cli: bad input files give FILE:LINE on one line, exit 1, no output") {
    const std::string header = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";  // lines 1-4
    check_errors(
        {
            {"number.obj", header + "v 0 0 abc\nf 1 2 3\n"},
            {"index.obj", header + "f 1 2 9\n"},
            {"two.obj", header + "f 1 2\n"},
            {"zero.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"},
            {"bent.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nf 1 2 3 4\n"},
            {"nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"},
            {"number.vs3",
             "T bad number\nF 3\nV 1 0 0 0\nV 2 1 0 0\nV 3 1 x 0\nV 4 0 1 0\n"
             "S 1 1 2 3 4 0 0 0.9 floor\nEnd\n"},
            {"record.vs3",
             "T unknown record\nF 3\nV 1 0 0 0\nV 2 1 0 0\nV 3 1 1 0\nV 4 0 1 0\n"
             "Q 1 2 3\nS 1 1 2 3 4 0 0 0.9 floor\nEnd\n"},
        },
        {
            {"compute missing.obj -o F.csv", 1, "missing.obj"},
            {"compute nosuch -o F.csv", 1, "nosuch"},
            {"compute number.obj -o F.csv", 1, "number.obj:5:"},
            {"compute index.obj -o F.csv", 1, "index.obj:5:"},
            {"compute two.obj -o F.csv", 1, "two.obj:5:"},
            {"compute zero.obj -o F.csv", 1, "zero.obj:4:"},
            {"compute bent.obj -o F.csv", 1, "bent.obj:5:"},
            {"compute nan.obj -o F.csv", 1, "nan.obj:3:"},
            {"compute number.vs3 -o F.csv", 1, "number.vs3:5:"},
            {"compute record.vs3 -o F.csv", 1, "record.vs3:7:"},
            {"info number.obj", 1, "number.obj:5:"},
            {"point index.obj --at 0 0 1 --normal 0 0 -1 -o F.csv", 1, "index.obj:5:"},
            {"run record.vs3", 1, "record.vs3:7:"},
            {"compute plates -o no/such/dir/F.csv", 1, "no/such/dir/F.csv"},
            {"compute plates -o F.csv --report no/r.json", 1, "no/r.json"},
            {"point plates --at 0 0 0 --normal 0 0 1 -o no/F.csv", 1, "no/F.csv"},
        });
}
