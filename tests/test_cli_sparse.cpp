// `formfactor compute --storage --threshold` with sparse outputs (.mtx, .h5), end to end.

#include <doctest/doctest.h>
#include <hdf5.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "formfactor/output/matrix_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/city.h"
#include "support/cli_runner.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::shell_quote;

namespace {

std::string said(const CliResult& r) { return "stdout:\n" + r.out + "stderr:\n" + r.err; }

std::string read_all(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

TEST_CASE("cli sparse: auto picks sparse for .mtx and says so") {
    Cli cli;
    const CliResult r = cli.run("compute city-2 -o F.mtx --threshold 1e-4 --report r.json");
    INFO(said(r));
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("storage    sparse (auto: -o is a sparse format") != std::string::npos);
    CHECK(r.out.find("peak") != std::string::npos);
    CHECK(cli.dir().entries() == 2);
    // The same entries as the library's sparse run (bit for bit through %.17g).
    SparseOptions so;
    so.threshold = 1e-4;
    const SparseFormFactors F = compute_sparse_form_factors(city_scene(2), {}, so).form_factors;
    std::istringstream in(read_all(cli.file("F.mtx")));
    std::string line;
    std::getline(in, line);
    CHECK(line == "%%MatrixMarket matrix coordinate real general");
    while (std::getline(in, line) && line[0] == '%') {
    }
    CHECK(line == "129 129 " + std::to_string(F.nonzeros()));
    std::size_t i = 0, j = 0, k = 0;
    std::string v;
    for (std::size_t row = 0; row < F.n; ++row)
        for (auto e = F.indptr[row]; e < F.indptr[row + 1]; ++e, ++k) {
            REQUIRE(static_cast<bool>(in >> i >> j >> v));
            CHECK(i == row + 1);
            CHECK(j == std::size_t(F.indices[std::size_t(e)]) + 1);
            CHECK(std::stod(v) == F.values[std::size_t(e)]);
        }
    CHECK(k == F.nonzeros());
    const auto report = nlohmann::json::parse(read_all(cli.file("r.json")));
    CHECK(report["storage"]["kind"] == "sparse");
    CHECK(report["storage"]["nonzeros"] == F.nonzeros());
    CHECK(report["memory"]["peak_bytes"].get<double>() > 0.0);
    CHECK(report["diagnostics"]["dropped_max"].get<double>() > 0.0);
}

TEST_CASE("cli sparse: .h5 with reciprocity repair and the patch table") {
    Cli cli;
    const CliResult r =
        cli.run("compute city-2 --storage sparse -o F.h5 --threshold 1e-3 --repair reciprocity");
    INFO(said(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("storage    sparse (asked for)") != std::string::npos);
    CHECK(r.out.find("repair     reciprocity") != std::string::npos);
    CHECK(cli.dir().entries() == 1);
    const hid_t f = H5Fopen(cli.file("F.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(f >= 0);
    CHECK(H5Lexists(f, "patches/centroid", H5P_DEFAULT) > 0);
    CHECK(H5Lexists(f, "sky_factor", H5P_DEFAULT) > 0);
    std::uint64_t n = 0;
    const hid_t a = H5Aopen(f, "N", H5P_DEFAULT);
    REQUIRE(a >= 0);
    H5Aread(a, H5T_NATIVE_UINT64, &n);
    H5Aclose(a);
    CHECK(n == 129);
    H5Fclose(f);
}

TEST_CASE("cli sparse: wrong combinations are one clear error and write nothing") {
    Cli cli;
    const struct {
        const char* args;
        const char* message;
    } cases[] = {
        {"compute city-1 -o F.csv --storage sparse", "formfactor: --storage: sparse storage"},
        {"compute city-1 -o F.mtx --storage dense", "formfactor: --storage: dense storage"},
        {"compute city-1 -o F.mtx --storage huge", "formfactor: --storage: must be auto"},
        {"compute city-1 -o F.npy --threshold 0.1", "formfactor: --threshold: applies to sparse"},
        {"compute city-1 -o F.mtx --threshold -1", "formfactor: --threshold: must be"},
        {"compute city-1 -o F.mtx --repair closure", "formfactor: --repair: closure needs"},
        {"compute city-1 -o F.h5 --stderr SE.npy", "formfactor: --stderr: with sparse storage"},
        {"compute city-1 -o F.npy --stderr SE.mtx", "formfactor: --stderr: with dense storage"},
        {"compute city-1 -o F.h5 --stderr SE.mtx", "formfactor: --stderr: method 'analytic'"},
        {"compute city-1 -o no/F.h5", "formfactor: no/F.h5: directory"},
    };
    for (const auto& c : cases) {
        const CliResult r = cli.run(c.args);
        INFO(c.args, said(r));
        CHECK(r.code != 0);
        CHECK(r.one_error_line());
        CHECK(r.err.rfind(c.message, 0) == 0);
    }
    CHECK(cli.dir().entries() == 0);
}

TEST_CASE("cli sparse: --stderr writes each stored entry's standard error in F's pattern") {
    // mc-hemisphere's sparse run: SE.mtx holds, for every entry of F.mtx, the standard error the
    // library's sparse run keeps for it (bit for bit through %.17g), and nothing else.
    Cli cli;
    const CliResult r = cli.run(
        "compute city-1 --method mc-hemisphere --samples 500 --seed 3 -o F.mtx --stderr SE.mtx");
    INFO(said(r));
    REQUIRE(r.code == 0);
    CHECK(cli.dir().entries() == 2);
    const SparseFormFactors F = read_sparse_matrix(cli.file("F.mtx"));
    const SparseFormFactors E = read_sparse_matrix(cli.file("SE.mtx"));
    ComputeOptions options;
    options.method = MethodKind::mc_hemisphere;
    options.method_options.samples = 500;
    options.method_options.seed = 3;
    const SparseFormFactors L =
        compute_sparse_form_factors(city_scene(1), options, {}).form_factors;
    REQUIRE(L.standard_error.has_value());
    REQUIRE(E.n == L.n);
    CHECK(E.indptr == L.indptr);
    CHECK(E.indices == L.indices);
    CHECK(F.indices == L.indices);
    CHECK(E.values == *L.standard_error);
    bool positive = false;
    for (double v : E.values) positive = positive || v > 0.0;
    CHECK(positive);
    // The same with .h5 outputs; a failing F write leaves no SE file behind.
    const CliResult h = cli.run(
        "compute city-1 --method mc-hemisphere --samples 500 --seed 3 -o F.h5 --stderr SE.h5");
    INFO(said(h));
    REQUIRE(h.code == 0);
    CHECK(read_sparse_matrix(cli.file("SE.h5")).values == *L.standard_error);
    // -o names a directory: the run fails (F cannot be written) and no standard errors stay.
    std::filesystem::create_directory(cli.file("G.h5"));
    const std::size_t before = cli.dir().entries();
    const CliResult bad =
        cli.run("compute city-1 --method mc-hemisphere --samples 500 -o G.h5 --stderr SE2.h5");
    INFO(said(bad));
    CHECK(bad.code != 0);
    CHECK(bad.one_error_line());
    CHECK(cli.dir().entries() == before);
}

TEST_CASE("cli sparse: --per-surface writes the surfaces' matrix, aggregated on the CSR") {
    Cli cli;
    CliResult r = cli.run("compute cube --subdivide 3 -o S.mtx --per-surface --report r.json");
    INFO(said(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("S.mtx (sparse, 6×6 per surface") != std::string::npos);
    r = cli.run("compute cube --subdivide 3 -o D.csv --per-surface");
    REQUIRE(r.code == 0);
    const SparseFormFactors S = read_sparse_matrix(cli.file("S.mtx"));
    const DenseMatrix D = read_matrix(cli.file("D.csv"));
    REQUIRE(S.n == 6);
    for (std::size_t g = 0; g < 6; ++g)
        for (std::size_t h = 0; h < 6; ++h)
            CHECK(std::abs(S.at(g, h) - D(Eigen::Index(g), Eigen::Index(h))) < 1e-15);
    const auto report = nlohmann::json::parse(read_all(cli.file("r.json")));
    CHECK(report["per_surface"]["N"] == 6);
    // The .h5 file of a per-surface matrix has no patch table (its rows are surfaces).
    r = cli.run("compute cube --subdivide 3 -o S.h5 --per-surface");
    REQUIRE(r.code == 0);
    const SparseFormFactors H = read_sparse_matrix(cli.file("S.h5"));
    CHECK(H.values == S.values);
    CHECK(H.areas.size() == 6);
}

TEST_CASE("cli sparse: analytic sparse rows that will not fit are refused before the pair lists") {
    // room-32 (7,680 patches, the box floating): 15.9 M pairs see each other (20.3 M less the
    // 4.3 M of visible node pairs that face away, never held), ~602 MB of pair lists by the
    // estimate; the whole run peaks at 460 MB RSS, 936 MB of address space. Under an
    // address-space limit of 550 MB the run stops after the classification with one line that
    // says what it needs, what is available and what to use instead, and writes nothing.
    // (prlimit is util-linux's, on every Debian system.)
    Cli cli;
    const std::string cmd = "cd " + shell_quote(cli.dir().path().string()) +
                            " && prlimit --as=550000000 " + shell_quote(FF_CLI_PATH) +
                            " compute room-32 -o F.h5 > out.txt 2> err.txt < /dev/null";
    const int status = std::system(cmd.c_str());
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 1);
    const std::string err = read_all(cli.file("err.txt"));
    INFO(err);
    CHECK(err.rfind("formfactor: analytic sparse rows: 15941056 pairs see each other", 0) == 0);
    CHECK(err.find("is available") != std::string::npos);
    CHECK(err.find("--storage hierarchical") != std::string::npos);
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(cli.file("F.h5")));
}
