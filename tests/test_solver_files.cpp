// Solver files and tables: Elmer's view-factor file (round trip, bad input), the VTU writer's
// checks, the patch table's row sums, the per-surface long table, and the CLI's use of them.

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/vtu.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::TempDir;

namespace {

std::string message_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

// A matrix with zeros (left out of the file), tiny and large values and full-precision digits.
DenseMatrix sample_matrix(int n) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    DenseMatrix F(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            F(i, j) = (i + j) % 3 == 0 ? 0.0 : u(rng) * std::pow(10.0, -(j % 7));
    return F;
}

DenseMatrix read_elmer_text(const std::string& text) {
    std::istringstream in(text);
    return read_elmer_view_factors(in, "vf.dat");
}

}  // namespace

TEST_CASE("elmer view factors: written and read back bit for bit, zeros left out") {
    const DenseMatrix F = sample_matrix(9);
    std::ostringstream out;
    write_elmer_view_factors(out, F);
    const std::string text = out.str();
    // Row 1 (i = 0): every third entry is zero, starting with j = 0.
    std::size_t zeros_in_row0 = 0;
    for (int j = 0; j < 9; ++j) zeros_in_row0 += F(0, j) == 0.0;
    CHECK(text.rfind(std::to_string(9 - zeros_in_row0) + "\n1 ", 0) == 0);
    const DenseMatrix G = read_elmer_text(text);
    REQUIRE(G.rows() == 9);
    REQUIRE(G.cols() == 9);
    CHECK((G.array() == F.array()).all());
}

TEST_CASE("elmer view factors: a row without entries is a count of 0, and reads back") {
    DenseMatrix F = DenseMatrix::Zero(3, 3);
    F(0, 2) = 0.25;
    F(2, 0) = 0.5;
    std::ostringstream out;
    write_elmer_view_factors(out, F);
    CHECK(out.str() == "1\n1 3 0.25\n0\n1\n3 1 0.5\n");
    CHECK((read_elmer_text(out.str()).array() == F.array()).all());
}

TEST_CASE("elmer view factors: bad files name the line") {
    CHECK(message_of([] { read_elmer_text(""); }) == "vf.dat: no rows (an empty view-factor file)");
    CHECK(message_of([] { read_elmer_text("2\n1 1 0.5\n"); }) ==
          "vf.dat:2: file ends with 1 entries of row 1 missing");
    CHECK(message_of([] { read_elmer_text("1\n2 1 0.5\n"); }) ==
          "vf.dat:2: row number '2' where row 1 is being read");
    CHECK(message_of([] { read_elmer_text("1\n1 3 0.5\n1\n2 1 0.5\n"); }) ==
          "vf.dat:2: column 3 is beyond the 2 rows of the file");
    CHECK(message_of([] { read_elmer_text("2\n1 2 0.5\n1 2 0.1\n0\n"); }) ==
          "vf.dat:3: column 2 appears twice in row 1");
    CHECK(message_of([] { read_elmer_text("1\n1 1 nan\n"); }) ==
          "vf.dat:2: non-finite value 'nan'");
    CHECK(message_of([] { read_elmer_text("1\n1 1 x\n"); }) == "vf.dat:2: malformed number 'x'");
    CHECK(message_of([] {
              read_elmer_text("1 2\n");
          }).rfind("vf.dat:1: expected the number of entries of row 1", 0) == 0);
    CHECK(message_of([] { read_elmer_text("1\n1 0.5\n"); }) ==
          "vf.dat:2: expected 'i j F' (row 1), got 2 values");
}

TEST_CASE("elmer view factors: .dat is a matrix format (write_matrix, read_matrix)") {
    TempDir dir;
    const DenseMatrix F = sample_matrix(5);
    CHECK(matrix_format_for("F.DAT") == MatrixFormat::ElmerDat);
    write_matrix(dir.file("F.dat"), F);
    CHECK((read_matrix(dir.file("F.dat")).array() == F.array()).all());
}

TEST_CASE("vtu: a field of the wrong size or name is refused and nothing is written") {
    TempDir dir;
    Scene scene = load_scene("cube");
    const std::size_t n = scene.patches.size();
    const std::string path = dir.file("x.vtu");
    CHECK(message_of([&] {
              write_vtu(path, scene, {VtuField{"area", 1, std::vector<double>(n + 1, 1.0)}});
          }) == "VTU field 'area' has 7 values for 6 patches × 1 components");
    CHECK(message_of([&] {
              write_vtu(path, scene, {VtuField{"a b", 1, std::vector<double>(n, 1.0)}});
          }) == "VTU field name 'a b' is not plain (letters, digits, _ - .)");
    CHECK(dir.entries() == 0);
}

TEST_CASE("vtu: form_factor_fields gives area, row sum, sky factor and the chosen row") {
    FormFactors ff;
    ff.F = DenseMatrix{{0.0, 0.25, 0.5}, {0.125, 0.0, 0.0}, {0.5, 0.25, 0.0}};
    ff.areas = {1.0, 2.0, 1.0};
    const std::vector<VtuField> fields = form_factor_fields(ff, std::size_t(2));
    REQUIRE(fields.size() == 4);
    CHECK(fields[0].name == "area");
    CHECK(fields[1].name == "row_sum");
    CHECK(fields[1].values == std::vector<double>{0.75, 0.125, 0.75});
    CHECK(fields[2].name == "sky_factor");
    CHECK(fields[2].values == std::vector<double>{0.25, 0.875, 0.25});
    CHECK(fields[3].name == "F_from_2");
    CHECK(fields[3].values == std::vector<double>{0.5, 0.25, 0.0});
    CHECK(message_of([&] { form_factor_fields(ff, std::size_t(3)); }) ==
          "row: patch 3 does not exist (the scene has 3 patches, 0 to 2)");
}

TEST_CASE("patch table: row_sum and sky_factor columns, and the long per-surface table") {
    Scene scene = load_scene("plates");
    const std::vector<double> sums = {0.25, 0.5};
    std::ostringstream out;
    write_patch_table(out, scene, sums);
    std::istringstream in(out.str());
    std::string header, row0, row1;
    std::getline(in, header);
    std::getline(in, row0);
    std::getline(in, row1);
    CHECK(header == "patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz,row_sum,sky_factor");
    CHECK(row0.substr(row0.size() - 10) == ",0.25,0.75");
    CHECK(row1.substr(row1.size() - 8) == ",0.5,0.5");
    CHECK_THROWS_AS(write_patch_table(out, scene, std::vector<double>{1.0}), Error);

    std::ostringstream pairs;
    write_pairs_csv(pairs, {"floor", "a,b"}, DenseMatrix{{0.0, 0.5}, {0.25, 0.0}});
    CHECK(pairs.str() ==
          "from,to,F\nfloor,floor,0\nfloor,\"a,b\",0.5\n\"a,b\",floor,0.25\n\"a,b\",\"a,b\",0\n");
}

TEST_CASE("cli: compute -o F.dat writes Elmer's file, and solve reads it with --matrix") {
    Cli cli;
    REQUIRE(cli.run("compute cube --subdivide 2 -o F.csv").code == 0);
    REQUIRE(cli.run("compute cube --subdivide 2 -o F.dat").code == 0);
    const DenseMatrix a = read_matrix(cli.file("F.csv"));
    const DenseMatrix b = read_matrix(cli.file("F.dat"));
    CHECK((a.array() == b.array()).all());
    const CliResult r = cli.run("solve cube --subdivide 2 --matrix F.dat -o B.csv");
    INFO(r.err);
    CHECK(r.code == 0);
}

TEST_CASE("cli: a .vtu output refuses per-surface rows and a --row out of range, writing nothing") {
    Cli cli;
    CliResult r = cli.run("compute cube -o F.vtu --per-surface");
    CHECK(r.code != 0);
    CHECK(r.err ==
          "formfactor: --per-surface: a .vtu file holds the patches (one cell per patch)\n");
    r = cli.run("compute cube -o F.vtu --row 6");
    CHECK(r.code != 0);
    CHECK(r.one_error_line());
    CHECK(r.err.find("patch 6 does not exist") != std::string::npos);
    r = cli.run("compute cube -o F.csv --row 1");
    CHECK(r.err == "formfactor: --row: puts a row of F into a .vtu output (-o F.vtu)\n");
    r = cli.run("compute cube -o F.csv --row-sums");
    CHECK(r.err == "formfactor: --row-sums: adds columns to the patch table (--patches P.csv)\n");
    CHECK(cli.dir().entries() == 0);
}
