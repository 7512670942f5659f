// `formfactor compute --per-surface / --per-patch`: View3D's per-surface output (subsurfaces
// cut out of their base, cmb surfaces combined), the default for .vs3 input.

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "formfactor/output/matrix_io.h"
#include "support/cli_runner.h"
#include "support/matrix_checks.h"

using namespace formfactor;
using formfactor::testing::check_row_sums;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::read_text;

namespace {

constexpr double kOpposite = 0.19982489569838746;  // unit cube, opposite faces
constexpr double kAdjacent = 0.20004377607540316;  // unit cube, adjacent faces

std::string describe(const CliResult& r) {
    return "exit " + std::to_string(r.code) + "\nstdout: " + r.out + "\nstderr: " + r.err;
}

std::string fixture(const std::string& name) {
    return formfactor::testing::shell_quote(std::string(FF_TEST_DATA_DIR) + "/" + name);
}

}  // namespace

TEST_CASE("cli: compute on a .vs3 writes one row per surface by default (View3D's output)") {
    Cli cli;
    CliResult r = cli.run("compute " + fixture("room-windows.vs3") +
                          " -o F.csv --report r.json --method analytic");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("N = 25 patches") != std::string::npos);
    CHECK(r.out.find("per surface") != std::string::npos);
    const DenseMatrix F = read_matrix(cli.file("F.csv"));
    REQUIRE(F.rows() == 12);
    check_row_sums(F, 1.0, 1e-9);
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["options"]["per_surface"] == true);
    CHECK(report["N"] == 25);                   // the computation
    REQUIRE(report["per_surface"]["N"] == 12);  // the matrix written
    CHECK(report["per_surface"]["rows"][2]["name"] == "south");
    CHECK(std::abs(report["per_surface"]["rows"][2]["area"].get<double>() - 8.2) < 1e-12);
    CHECK(report["per_surface"]["rows"][3]["surfaces"] == nlohmann::json::array({3}));

    // View3D's text format: the areas are the separated ones.
    r = cli.run("compute " + fixture("room-windows.vs3") + " -o F.txt");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    std::istringstream in(read_text(cli.file("F.txt")));
    const View3dFile f = read_view3d_text(in, "F.txt");
    REQUIRE(f.F.rows() == 12);
    CHECK(f.areas[2] == doctest::Approx(8.2));
    CHECK(f.areas[6] == doctest::Approx(0.92));
    CHECK(f.encl == 1);

    // Standard errors (Monte Carlo) are aggregated per surface too.
    r = cli.run("compute " + fixture("room-windows.vs3") +
                " -o M.csv --stderr S.csv --method mc-target --samples 64");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const DenseMatrix S = read_matrix(cli.file("S.csv"));
    REQUIRE(S.rows() == 12);
    CHECK(S.minCoeff() >= 0.0);
    CHECK(read_matrix(cli.file("M.csv")).rows() == 12);

    // --per-patch: the patch matrix.
    r = cli.run("compute " + fixture("room-windows.vs3") + " -o P.csv --per-patch");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(read_matrix(cli.file("P.csv")).rows() == 25);
}

TEST_CASE("cli: --per-surface on a subdivided cube gives the cube, the flags exclude each other") {
    Cli cli;
    CliResult r = cli.run("compute cube --subdivide 4 --per-surface -o F.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const DenseMatrix F = read_matrix(cli.file("F.csv"));
    REQUIRE(F.rows() == 6);
    for (Eigen::Index i = 0; i < 6; ++i)
        for (Eigen::Index j = 0; j < 6; ++j)
            CHECK(std::abs(F(i, j) - (i == j           ? 0.0
                                      : i / 2 == j / 2 ? kOpposite
                                                       : kAdjacent)) < 1e-10);
    // Built-in scenes and OBJ default to one row per patch.
    r = cli.run("compute cube --subdivide 2 -o G.csv");
    REQUIRE(r.code == 0);
    CHECK(read_matrix(cli.file("G.csv")).rows() == 24);
    r = cli.run("compute cube -o H.csv --per-surface --per-patch");
    CHECK(r.code == 2);
    CHECK(r.one_error_line());
    CHECK(r.err.find("--per-surface") != std::string::npos);
}

TEST_CASE("cli compute --storage hierarchical --per-surface: the cube's exact face factors") {
    Cli cli;
    // 6 × 16 × 16 = 1,536 patches (384 compressed blocks): the per-surface matrix from 6
    // products of the operator.
    CliResult r = cli.run(
        "compute cube --subdivide 16 --storage hierarchical --per-surface -o S.npy --report "
        "r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("operator   hierarchical") != std::string::npos);
    const DenseMatrix S = read_matrix(cli.file("S.npy"));
    REQUIRE(S.rows() == 6);
    for (Eigen::Index i = 0; i < 6; ++i)
        for (Eigen::Index j = 0; j < 6; ++j) {
            if (i == j) {
                CHECK(S(i, j) == 0.0);
                continue;
            }
            // Opposite faces: x0/x1, y0/y1, z0/z1 (surfaces 2k, 2k+1).
            const double exact = i / 2 == j / 2 ? kOpposite : kAdjacent;
            CHECK(std::abs(S(i, j) - exact) <= 1e-7);
        }
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["storage"]["kind"] == "hierarchical");
    CHECK(report["per_surface"]["N"] == 6);
    // The patch matrix is N x N: refused, as are the options that need F's entries.
    for (const char* bad : {"compute cube --subdivide 4 --storage hierarchical -o F.npy",
                            "compute cube --subdivide 4 --storage hierarchical --per-surface "
                            "--repair both -o F.npy",
                            "compute cube --subdivide 4 --storage hierarchical --per-surface "
                            "--method mc-area -o F.npy",
                            "compute cornell --storage hierarchical --per-surface -o F.npy"}) {
        r = cli.run(bad);
        INFO(bad << "\n" << describe(r));
        CHECK(r.code != 0);
        CHECK_FALSE(std::filesystem::exists(cli.file("F.npy")));
    }
}
