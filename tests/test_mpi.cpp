// `mpirun -np K formfactor ...` against one process, end to end (test suite "mpi"; only when the
// library was built with MPI and CMake found mpiexec, FF_TEST_MPIEXEC).

#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "formfactor/output/sparse_io.h"
#include "support/cli_runner.h"

#ifdef FF_TEST_MPIEXEC

using namespace formfactor;
using formfactor::testing::read_text;
using formfactor::testing::shell_quote;
using formfactor::testing::TempDir;
using formfactor::testing::write_text;

namespace {

struct Run {
    int code = -1;
    std::string out, err;
    double seconds = 0;
};

// The shell command `cmd` in `dir`, its output captured and its wall time measured.
Run run_shell(const TempDir& dir, const std::string& cmd) {
    TempDir capture;
    const std::string out = capture.file("stdout.txt"), err = capture.file("stderr.txt");
    const std::string line = "cd " + shell_quote(dir.path().string()) + " && (" + cmd + ") > " +
                             shell_quote(out) + " 2> " + shell_quote(err) + " < /dev/null";
    const auto start = std::chrono::steady_clock::now();
    const int status = std::system(line.c_str());
    Run r;
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.out = read_text(out);
    r.err = read_text(err);
    return r;
}

// mpirun with `ranks` ranks (oversubscribed, unbound, as root when root); `env` is a VAR=VALUE
// exported to every rank, or empty.
std::string mpirun(int ranks, const std::string& env = "") {
    std::string launcher = shell_quote(FF_TEST_MPIEXEC) + " -np " + std::to_string(ranks) +
                           " --oversubscribe --bind-to none";
    if (::geteuid() == 0) launcher += " --allow-run-as-root";
    if (!env.empty()) launcher += " -x " + env;
    return launcher;
}

// `formfactor ARGS` in `dir`, under mpirun with `ranks` ranks (0: no mpirun).
Run run(const TempDir& dir, int ranks, const std::string& args, const std::string& env = "") {
    const std::string launcher = ranks > 0 ? mpirun(ranks, env) + " " : std::string();
    return run_shell(dir, launcher + shell_quote(FF_CLI_PATH) + " " + args);
}

std::string said(const Run& r) { return "stdout:\n" + r.out + "stderr:\n" + r.err; }

// Replaces every "{}" of `text` with `tag`.
std::string tagged(std::string text, const std::string& tag) {
    for (auto at = text.find("{}"); at != std::string::npos; at = text.find("{}", at))
        text.replace(at, 2, tag);
    return text;
}

// `formfactor ARGS` on one process and on 2 and 3 ranks ("{}" in ARGS and FILES: 1, 2 or 3):
// the bytes of each of FILES are the same in the three runs.
void check_same_files_on_any_rank_count(const std::string& args,
                                        const std::vector<std::string>& files,
                                        const std::string& two_zone_model = "") {
    TempDir dir;
    if (!two_zone_model.empty()) write_text(dir.file("two.idf"), two_zone_model);
    write_text(dir.file("p.csv"),
               "surface,emissivity,temperature\nx0,1,300\nx1,0.5,300\ny0,1,300\ny1,1,300\n"
               "z0,0.6,1000\nz1,0.8,400\n");
    const Run one = run(dir, 0, tagged(args, "1"));
    INFO(said(one));
    REQUIRE(one.code == 0);
    for (int ranks : {2, 3}) {
        CAPTURE(ranks);
        const std::string tag = std::to_string(ranks);
        const Run r = run(dir, ranks, tagged(args, tag));
        INFO(said(r));
        REQUIRE(r.code == 0);
        CHECK(r.out.find("ranks      " + tag + " × ") != std::string::npos);
        for (const std::string& file : files) {
            CAPTURE(file);
            const std::string expected = read_text(dir.file(tagged(file, "1")));
            REQUIRE(!expected.empty());
            CHECK(read_text(dir.file(tagged(file, tag))) == expected);
        }
    }
}

}  // namespace

TEST_CASE(
    "mpi: analytic F of an obstructed room is bit-identical on 2 and 3 ranks as on one process" *
    doctest::test_suite("mpi")) {
    check_same_files_on_any_rank_count(
        "compute room-4-obstruction --method analytic --threads 1 -o F{}.npy --patches P{}.csv",
        {"F{}.npy", "P{}.csv"});
}

namespace {

// The number after the first `"key": ` of a JSON text (-1 when absent).
double json_number(const std::string& text, const std::string& key) {
    const auto at = text.find("\"" + key + "\":");
    if (at == std::string::npos) return -1.0;
    return std::stod(text.substr(at + key.size() + 3));
}

// The numbers of "partly hidden pairs A / B / ... in" of a run's ranks line.
std::vector<double> pairs_per_rank(const std::string& out) {
    std::vector<double> got;
    auto at = out.find("partly hidden pairs ");
    if (at == std::string::npos) return got;
    std::istringstream in(out.substr(at + 20));
    std::string word;
    while (in >> word && word != "in")
        if (word != "/") got.push_back(std::stod(word));
    return got;
}

}  // namespace

TEST_CASE(
    "mpi: the analytic method integrates each partly hidden pair once over 2 and 3 ranks with "
    "one process's F dense and sparse" *
    doctest::test_suite("mpi")) {
    TempDir dir;
    const std::string scene = "compute room-6-obstruction --method analytic --threads 1 ";
    const Run one = run(dir, 0, scene + "-o F1.npy --report R1.json");
    INFO(said(one));
    REQUIRE(one.code == 0);
    const Run one_sparse = run(dir, 0, scene + "-o S1.h5");
    INFO(said(one_sparse));
    REQUIRE(one_sparse.code == 0);
    const std::string report = read_text(dir.file("R1.json"));
    const double pairs = json_number(report, "patch_pairs_partly_hidden");
    const double points = json_number(report, "point_evaluations");
    REQUIRE(pairs > 100);
    REQUIRE(points > 0);
    const SparseFormFactors expected = read_sparse_matrix(dir.file("S1.h5"));
    REQUIRE(expected.nonzeros() > 0);
    for (int ranks : {2, 3}) {
        CAPTURE(ranks);
        const std::string tag = std::to_string(ranks);
        const Run r = run(dir, ranks, scene + "-o F" + tag + ".npy --report R" + tag + ".json");
        INFO(said(r));
        REQUIRE(r.code == 0);
        CHECK(read_text(dir.file("F" + tag + ".npy")) == read_text(dir.file("F1.npy")));
        // Every pair once over the ranks: the pairs each rank did add up to the scene's, and
        // the point evaluations of the integration are one process's.
        const std::vector<double> shares = pairs_per_rank(r.out);
        CHECK(shares.size() == static_cast<std::size_t>(ranks));
        double sum = 0.0;
        for (double v : shares) sum += v;
        CHECK(sum == pairs);
        const std::string got = read_text(dir.file("R" + tag + ".json"));
        CHECK(json_number(got, "patch_pairs_partly_hidden") == pairs);
        CHECK(json_number(got, "point_evaluations") == points);

        const Run rs = run(dir, ranks, scene + "-o S" + tag + ".h5");
        INFO(said(rs));
        REQUIRE(rs.code == 0);
        CHECK(pairs_per_rank(rs.out).size() == static_cast<std::size_t>(ranks));
        CHECK(read_text(dir.file("S" + tag + ".h5")) == read_text(dir.file("S1.h5")));
    }
}

TEST_CASE(
    "mpi: an analytic solve of an obstructed scene over the ranks writes one process's solution "
    "from dense and sparse rows" *
    doctest::test_suite("mpi")) {
    // Rows kept on their ranks (the pairs' values go to every rank first), GMRES over the ranks.
    check_same_files_on_any_rank_count(
        "solve cornell --subdivide 2 --method analytic --solver gmres --threads 1 -o B{}.csv",
        {"B{}.csv"});
    check_same_files_on_any_rank_count(
        "solve cornell --subdivide 2 --method analytic --storage sparse --solver gmres --threads 1 "
        "-o B{}.csv",
        {"B{}.csv"});
}

TEST_CASE(
    "mpi: mc-hemisphere F and its standard errors are bit-identical on 2 and 3 ranks as on one "
    "process" *
    doctest::test_suite("mpi")) {
    check_same_files_on_any_rank_count(
        "compute cornell --subdivide 2 --method mc-hemisphere --samples 2000 --threads 1 -o "
        "F{}.npy "
        "--stderr SE{}.npy",
        {"F{}.npy", "SE{}.npy"});
}

TEST_CASE(
    "mpi: analytic F where nothing obstructs is bit-identical on 2 and 3 ranks (blocks of the "
    "upper triangle and the rest by reciprocity on rank 0)" *
    doctest::test_suite("mpi")) {
    check_same_files_on_any_rank_count(
        "compute cube --subdivide 10 --method analytic --threads 1 -o F{}.npy", {"F{}.npy"});
}

TEST_CASE(
    "mpi: sparse analytic F where nothing obstructs is one process's on 2 and 3 ranks with each "
    "pair computed once (blocks of the upper triangle and the rest by reciprocity on rank 0)" *
    doctest::test_suite("mpi")) {
    // Patches of unequal areas, so that an entry and its reciprocal fall on different sides of
    // the threshold.
    const std::string args =
        "compute cornell-empty --subdivide 4 --method analytic --threshold 2e-3 --threads 1 ";
    check_same_files_on_any_rank_count(args + "-o F{}.mtx", {"F{}.mtx"});
    TempDir dir;
    const Run one = run(dir, 0, args + "-o F1.h5 --report R1.json");
    INFO(said(one));
    REQUIRE(one.code == 0);
    const double evaluations =
        json_number(read_text(dir.file("R1.json")), "far_field_kernel_evaluations");
    REQUIRE(evaluations > 0);
    const Run two = run(dir, 2, args + "-o F2.h5 --report R2.json");
    INFO(said(two));
    REQUIRE(two.code == 0);
    CHECK(json_number(read_text(dir.file("R2.json")), "far_field_kernel_evaluations") ==
          evaluations);
}

TEST_CASE("mpi: hemicube F is bit-identical on 2 and 3 ranks as on one process" *
          doctest::test_suite("mpi")) {
    check_same_files_on_any_rank_count(
        "compute cornell --subdivide 3 --method hemicube --resolution 64 --threads 2 -o F{}.npy",
        {"F{}.npy"});
}

TEST_CASE("mpi: sparse .mtx is bit-identical on 2 and 3 ranks as on one process" *
          doctest::test_suite("mpi")) {
    // Rows the method emits sparse (analytic, obstructed), and dense blocks made sparse on
    // their rank (hemicube).
    check_same_files_on_any_rank_count(
        "compute room-4-obstruction --method analytic --threshold 1e-3 --threads 1 -o F{}.mtx",
        {"F{}.mtx"});
    check_same_files_on_any_rank_count(
        "compute cornell --subdivide 2 --method hemicube --resolution 64 --threshold 1e-4 --repair "
        "reciprocity --threads 1 -o F{}.mtx",
        {"F{}.mtx"});
}

TEST_CASE("mpi: thermal and radiosity solves write the same solution on 2 and 3 ranks" *
          doctest::test_suite("mpi")) {
    // F over the ranks, gathered and solved on rank 0 (the direct solve, exchange factors).
    check_same_files_on_any_rank_count(
        "solve cube --subdivide 3 --thermal --properties p.csv --threads 1 -o T{}.csv "
        "--exchange-factors X{}.csv",
        {"T{}.csv", "X{}.csv"});
    // Rows kept on their ranks and GMRES over the ranks: one process's solution bit for bit.
    check_same_files_on_any_rank_count(
        "solve cornell --subdivide 2 --method mc-hemisphere --samples 400 --storage sparse "
        "--solver gmres --threads 1 -o B{}.csv",
        {"B{}.csv"});
}

TEST_CASE(
    "mpi: a thermal solve over the ranks with gmres and jacobi on dense and sparse rows writes one "
    "process's solution bit for bit" *
    doctest::test_suite("mpi")) {
    check_same_files_on_any_rank_count(
        "solve cube --subdivide 4 --thermal --properties p.csv --solver gmres --threads 1 -o "
        "T{}.csv",
        {"T{}.csv"});
    check_same_files_on_any_rank_count(
        "solve cube --subdivide 3 --method hemicube --resolution 64 --thermal --properties p.csv "
        "--solver jacobi --threads 2 -o J{}.csv",
        {"J{}.csv"});
    check_same_files_on_any_rank_count(
        "solve cube --subdivide 4 --thermal --properties p.csv --storage sparse --threshold 1e-4 "
        "--threads 1 -o S{}.csv",
        {"S{}.csv"});
}

namespace {

// Column `name` of a CSV table with a header row.
std::vector<double> csv_column(const std::string& text, const std::string& name) {
    std::vector<double> out;
    std::istringstream in(text);
    std::string line;
    std::getline(in, line);
    std::size_t column = 0;
    {
        std::istringstream header(line);
        std::string cell;
        while (std::getline(header, cell, ',') && cell != name) ++column;
    }
    while (std::getline(in, line)) {
        std::istringstream row(line);
        std::string cell;
        for (std::size_t k = 0; k <= column && std::getline(row, cell, ','); ++k) {
        }
        out.push_back(std::stod(cell));
    }
    return out;
}

}  // namespace

TEST_CASE(
    "mpi: a solve on the hierarchical operator spread over 2 and 3 ranks writes one process's "
    "solution bit for bit" *
    doctest::test_suite("mpi")) {
    // Each rank computes a share of the blocks and holds a run of the operator's chunks; the
    // partial sums of every product go from rank to rank in chunk order, so every product is
    // summed as one process sums it: the tolerance is zero.
    check_same_files_on_any_rank_count(
        "solve cube --subdivide 8 --storage hierarchical --thermal --properties p.csv "
        "--threads 1 -o H{}.csv --report R{}.json",
        {"H{}.csv"});
    // Radiosity (three channels) by Jacobi, two threads a rank.
    TempDir dir;
    write_text(dir.file("rgb.csv"),
               "surface,reflectance_r,reflectance_g,reflectance_b,emission_r,emission_g,"
               "emission_b\nz1,0.5,0.5,0.5,10,8,6\nx0,0.8,0.3,0.2,0,0,0\ny1,0.2,0.7,0.4,0,0,0\n");
    const std::string args =
        "solve cube --subdivide 12 --properties rgb.csv --storage hierarchical --solver jacobi "
        "--threads 2 -o ";
    const Run one = run(dir, 0, args + "B1.csv");
    INFO(said(one));
    REQUIRE(one.code == 0);
    const std::string expected = read_text(dir.file("B1.csv"));
    REQUIRE(csv_column(expected, "radiosity_r").size() == 864);
    for (int ranks : {2, 3}) {
        CAPTURE(ranks);
        const std::string name = "B" + std::to_string(ranks) + ".csv";
        const Run r = run(dir, ranks, args + name);
        INFO(said(r));
        REQUIRE(r.code == 0);
        CHECK(r.out.find("ranks      " + std::to_string(ranks) + " × 2 threads: partition ") !=
              std::string::npos);
        CHECK(read_text(dir.file(name)) == expected);
    }
}

namespace {

// `formfactor ARGS` on 3 ranks in `dir`, once with each of `failures` (a VAR=VALUE for every
// rank, and the rank it makes fail): every run ends within 10 s with exit code 1 and one line
// from formfactor naming that rank and its injected failure, and writes nothing (the folder
// keeps its `entries` files).
void check_injected_failures(const TempDir& dir, const std::string& args,
                             const std::vector<std::pair<std::string, std::string>>& failures,
                             std::size_t entries) {
    for (const auto& [variable, failing] : failures) {
        // Copies: clang's doctest CAPTURE (a lambda) cannot name a structured binding.
        const std::string env = variable, rank = failing;
        CAPTURE(env);
        const Run r = run(dir, 3, args, env);
        INFO(said(r));
        CHECK(r.code == 1);
        CHECK(r.err.find("formfactor: rank " + rank + ": a failure injected on rank " + rank) !=
              std::string::npos);
        const auto first = r.err.find("formfactor:");
        CHECK(r.err.find("formfactor:", first + 1) == std::string::npos);
        CHECK(r.seconds < 10.0);
        CHECK(dir.entries() == entries);
    }
}

}  // namespace

TEST_CASE("mpi: a rank that fails building or applying the hierarchical operator ends every rank" *
          doctest::test_suite("mpi")) {
    TempDir dir;
    write_text(dir.file("p.csv"), "surface,temperature\nx0,300\nz1,1000\n");
    check_injected_failures(
        dir,
        "solve cube --subdivide 6 --storage hierarchical --thermal "
        "--properties p.csv --threads 1 -o T.csv --report r.json",
        {{"FORMFACTOR_TEST_FAIL_RANK=1", "1"}, {"FORMFACTOR_TEST_FAIL_SOLVE_RANK=2", "2"}},
        1);  // p.csv alone
}

TEST_CASE(
    "mpi: the per-surface matrix of the hierarchical operator over 2 and 3 ranks is one "
    "process's bit for bit" *
    doctest::test_suite("mpi")) {
    // One product with every surface's indicator column, its partial sums handed from rank to
    // rank in chunk order as a solve's: the tolerance is zero.
    check_same_files_on_any_rank_count(
        "compute cube --subdivide 6 --storage hierarchical --per-surface --threads 1 -o S{}.npy "
        "--report R{}.json",
        {"S{}.npy"});
    // The 10 surfaces of the empty Cornell box (an open one) with two threads a rank, and the
    // report's account of the ranks.
    check_same_files_on_any_rank_count(
        "compute cornell-empty --subdivide 6 --storage hierarchical --per-surface --threads 2 "
        "-o S{}.csv",
        {"S{}.csv"});
    TempDir dir;
    const Run r = run(dir, 2,
                      "compute cube --subdivide 6 --storage hierarchical --per-surface --threads 1 "
                      "-o S.npy --report r.json");
    INFO(said(r));
    REQUIRE(r.code == 0);
    const auto report = nlohmann::json::parse(read_text(dir.file("r.json")));
    CHECK(report["details"]["mpi"]["ranks"] == 2);
    CHECK(report["details"]["mpi"]["blocks_computed_per_rank"].size() == 2);
}

TEST_CASE(
    "mpi: a rank that fails building or applying the operator of the per-surface matrix ends "
    "every rank and writes nothing" *
    doctest::test_suite("mpi")) {
    TempDir dir;
    check_injected_failures(
        dir,
        "compute cube --subdivide 6 --storage hierarchical --per-surface "
        "--threads 1 -o S.npy --report r.json",
        {{"FORMFACTOR_TEST_FAIL_RANK=1", "1"}, {"FORMFACTOR_TEST_FAIL_SOLVE_RANK=2", "2"}}, 0);
}

TEST_CASE(
    "mpi: the hierarchical operator's memory check asks each rank for its share: refused on one "
    "process and built on 3 ranks" *
    doctest::test_suite("mpi")) {
    // cube --subdivide 90 (48,600 patches): the whole operator is estimated at 752 MB (404 MB
    // of per-patch tables and tree, which every rank holds, and 348 MB of blocks); each of 3
    // ranks at 636 MB (the tables, the 116 MB of blocks it computes and a third of all blocks,
    // its run of chunks). Under an address-space limit of 700 MB, which the ranks fit in, one
    // process is refused before anything is computed and 3 ranks build and solve. (prlimit is
    // util-linux's; the limit holds for mpirun and every rank it starts.)
    TempDir dir;
    write_text(dir.file("p.csv"), "surface,emissivity,temperature\nx0,0.5,300\nz1,0.8,1000\n");
    const std::string limit = "prlimit --as=700000000 ";
    const std::string args =
        " solve cube --subdivide 90 --storage hierarchical --error-target 0.1 --thermal "
        "--properties p.csv --threads 1 -o T.csv --report r.json";
    const Run one = run_shell(dir, limit + shell_quote(FF_CLI_PATH) + args);
    INFO(said(one));
    CHECK(one.code == 1);
    CHECK(one.err.find("formfactor: hierarchical operator of 48600 patches: needs about 0.8 GB") !=
          std::string::npos);
    CHECK(one.err.find("0.7 GB available") != std::string::npos);
    CHECK(dir.entries() == 1);  // p.csv alone
    const Run three = run_shell(dir, limit + mpirun(3) + " " + shell_quote(FF_CLI_PATH) + args);
    INFO(said(three));
    REQUIRE(three.code == 0);
    CHECK(three.out.find("ranks      3 × 1 thread: ") != std::string::npos);
    const auto report = nlohmann::json::parse(read_text(dir.file("r.json")));
    const auto& estimated = report["details"]["mpi"]["estimated_bytes_per_rank"];
    REQUIRE(estimated.size() == 3);
    for (const auto& bytes : estimated) {
        CHECK(bytes.get<double>() > 0.6e9);
        CHECK(bytes.get<double>() < 0.7e9);
    }
    CHECK(csv_column(read_text(dir.file("T.csv")), "radiosity").size() == 48600);
}

TEST_CASE(
    "mpi: a sparse run that will not fit on rank 0 stops after its first blocks with the memory "
    "message" *
    doctest::test_suite("mpi")) {
    // cube --subdivide 60 (21,600 patches) with threshold 0 keeps 83 % of all pairs: a CSR of
    // 388.8 M entries, 4.7 GB, which rank 0 gathers. Under an address-space limit of 1.5 GB the
    // first block's entries, extrapolated to every row, say so before the CSR grows.
    TempDir dir;
    const Run r =
        run_shell(dir, "prlimit --as=1500000000 " + mpirun(2) + " " + shell_quote(FF_CLI_PATH) +
                           " compute cube --subdivide 60 --threshold 0 --threads 1 "
                           "-o F.h5 --report r.json");
    INFO(said(r));
    CHECK(r.code == 1);
    CHECK(r.err.find("formfactor: not enough memory: the sparse run of 21,600 patches needs "
                     "about") != std::string::npos);
    // The CSR of every row, with the entries below the diagonal waiting for their rows.
    CHECK(r.err.find("entries 4.7 GB") != std::string::npos);
    CHECK(r.seconds < 30.0);
    CHECK(dir.entries() == 0);
}

TEST_CASE(
    "mpi: a Gauss-Seidel thermal solve over 2 and 3 ranks is the serial one to the tolerance "
    "and repeats bit for bit" *
    doctest::test_suite("mpi")) {
    TempDir dir;
    write_text(dir.file("p.csv"),
               "surface,emissivity,temperature\nx0,1,300\nx1,0.5,300\ny0,1,300\ny1,0.3,300\n"
               "z0,0.6,1000\nz1,0.8,400\n");
    const std::string args =
        "solve cube --subdivide 4 --thermal --properties p.csv --solver gauss-seidel "
        "--residual 1e-11 --threads 1 -o ";
    const Run one = run(dir, 0, args + "T1.csv");
    INFO(said(one));
    REQUIRE(one.code == 0);
    const std::vector<double> serial = csv_column(read_text(dir.file("T1.csv")), "radiosity");
    REQUIRE(serial.size() == 96);
    double scale = 0.0;
    for (double v : serial) scale = std::max(scale, std::abs(v));
    for (int ranks : {2, 3}) {
        CAPTURE(ranks);
        std::string first;
        for (int repeat = 0; repeat < 2; ++repeat) {
            const std::string name = "T" + std::to_string(ranks) + "-" + std::to_string(repeat);
            const Run r = run(dir, ranks, args + name + ".csv");
            INFO(said(r));
            REQUIRE(r.code == 0);
            CHECK(r.out.find("solved over the ranks") != std::string::npos);
            const std::string text = read_text(dir.file(name + ".csv"));
            if (repeat == 0) first = text;
            CHECK(text == first);
            const std::vector<double> got = csv_column(text, "radiosity");
            REQUIRE(got.size() == serial.size());
            for (std::size_t i = 0; i < got.size(); ++i)
                CHECK(std::abs(got[i] - serial[i]) <= 1e-9 * scale);
        }
    }
}

TEST_CASE("mpi: a rank that fails during a distributed solve ends every rank with its message" *
          doctest::test_suite("mpi")) {
    TempDir dir;
    write_text(dir.file("p.csv"), "surface,temperature\nx0,300\nz1,1000\n");
    check_injected_failures(dir,
                            "solve cube --subdivide 4 --thermal --properties p.csv --solver gmres "
                            "--threads 1 -o T.csv --report r.json",
                            {{"FORMFACTOR_TEST_FAIL_SOLVE_RANK=2", "2"}},
                            1);  // p.csv alone
}

TEST_CASE("mpi: every zone of a model (one job per zone) gives the same EnergyPlus file" *
          doctest::test_suite("mpi")) {
    // Two zones: the same room under other names (as the EnergyPlus output tests build it).
    const std::string model =
        read_text(std::string(FF_TEST_DATA_DIR) + "/energyplus/1ZoneUncontrolled_win_1.idf");
    std::string second = model.substr(model.find("  Zone,"));
    second = second.substr(0, second.find("  GlobalGeometryRules,")) +
             second.substr(second.find("  BuildingSurface:Detailed,"));
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"ZONE ONE", "ZONE TWO"}, {"Zn001", "Zn002"}})
        for (std::size_t at = 0; (at = second.find(from, at)) != std::string::npos; at += to.size())
            second.replace(at, from.size(), to);
    check_same_files_on_any_rank_count(
        "compute two.idf --all-zones --subdivide 2 --threads 1 -o vf{}.idf", {"vf{}.idf"},
        model + second);
}

TEST_CASE("mpi: solve --all-zones writes one process's files for every zone on 2 and 3 ranks" *
          doctest::test_suite("mpi")) {
    // Two zones (the room of the EnergyPlus test under two names), each with a hot floor; each
    // zone is solved over the ranks in turn (gmres: rows kept on their ranks) or gathered on
    // rank 0 (the direct solve), and its files are written with the others after the last zone.
    const std::string model =
        read_text(std::string(FF_TEST_DATA_DIR) + "/energyplus/1ZoneUncontrolled_win_1.idf");
    std::string second = model.substr(model.find("  Zone,"));
    second = second.substr(0, second.find("  GlobalGeometryRules,")) +
             second.substr(second.find("  BuildingSurface:Detailed,"));
    for (const auto& [from, to] :
         {std::pair<std::string, std::string>{"ZONE ONE", "ZONE TWO"}, {"Zn001", "Zn002"}})
        for (std::size_t at = 0; (at = second.find(from, at)) != std::string::npos; at += to.size())
            second.replace(at, from.size(), to);
    for (const std::string solver : {"gmres", "direct"}) {
        CAPTURE(solver);
        TempDir dir;
        write_text(dir.file("two.idf"), model + second);
        write_text(dir.file("T_ZONE_ONE.csv"),
                   "surface,emissivity,temperature\nZn001:Flr001,0.9,350\n");
        write_text(dir.file("T_ZONE_TWO.csv"),
                   "surface,emissivity,temperature\nZn002:Flr001,0.8,400\n");
        const std::string args =
            "solve two.idf --all-zones --subdivide 2 --thermal --properties T.csv --solver " +
            solver + " --threads 1 -o J{}.csv";
        const Run one = run(dir, 0, tagged(args, "1"));
        INFO(said(one));
        REQUIRE(one.code == 0);
        for (int ranks : {2, 3}) {
            CAPTURE(ranks);
            const std::string tag = std::to_string(ranks);
            const Run r = run(dir, ranks, tagged(args, tag));
            INFO(said(r));
            REQUIRE(r.code == 0);
            CHECK(r.out.find("wrote      2 files for 2 zones\n") != std::string::npos);
            for (const std::string zone : {"_ZONE_ONE.csv", "_ZONE_TWO.csv"}) {
                CAPTURE(zone);
                const std::string expected = read_text(dir.file("J1" + zone));
                REQUIRE(!expected.empty());
                CHECK(read_text(dir.file("J" + tag + zone)) == expected);
            }
        }
    }
    // The second zone fails (its properties name a surface of the first) after the first was
    // solved over the ranks: one message, exit 1, no file written.
    TempDir dir;
    write_text(dir.file("two.idf"), model + second);
    write_text(dir.file("T_ZONE_ONE.csv"),
               "surface,emissivity,temperature\nZn001:Flr001,0.9,350\n");
    write_text(dir.file("T_ZONE_TWO.csv"),
               "surface,emissivity,temperature\nZn001:Flr001,0.8,400\n");
    const Run r = run(dir, 2,
                      "solve two.idf --all-zones --subdivide 2 --thermal --properties T.csv "
                      "--solver gmres --threads 1 -o J.csv");
    INFO(said(r));
    CHECK(r.code == 1);
    CHECK(r.out.find("zone       ZONE TWO\n") != std::string::npos);
    CHECK(r.err.find("formfactor: T_ZONE_TWO.csv:2: unknown surface 'Zn001:Flr001'\n") !=
          std::string::npos);
    CHECK(dir.entries() == 3);  // the model and the two property files
}

TEST_CASE(
    "mpi: sparse .h5 from mc-hemisphere has the same bytes on 2 and 3 ranks as on one process" *
    doctest::test_suite("mpi")) {
    TempDir dir;
    const std::string args =
        "city-2 --method mc-hemisphere --samples 4000 --threads 1 --repair reciprocity -o ";
    const Run one = run(dir, 0, "compute " + args + "one.h5");
    INFO(said(one));
    REQUIRE(one.code == 0);
    const SparseFormFactors expected = read_sparse_matrix(dir.file("one.h5"));
    REQUIRE(expected.nonzeros() > 0);
    for (int ranks : {2, 3}) {
        CAPTURE(ranks);
        const std::string name = std::to_string(ranks) + ".h5";
        const Run r = run(dir, ranks, "compute " + args + name);
        INFO(said(r));
        REQUIRE(r.code == 0);
        CHECK(read_text(dir.file(name)) == read_text(dir.file("one.h5")));
    }
}

TEST_CASE("mpi: a failure on rank 1 ends every rank at once with its message and no output" *
          doctest::test_suite("mpi")) {
    TempDir dir;
    // Over 30 s on one thread when nothing fails (3.6 s at --subdivide 8): the failure ends it
    // well before.
    const Run r = run(dir, 2,
                      "compute cornell --subdivide 16 --method analytic --threads 1 -o F.npy "
                      "--report r.json",
                      "FORMFACTOR_TEST_FAIL_RANK=1");
    INFO(said(r));
    CHECK(r.code != 0);
    CHECK(r.err.find("formfactor: rank 1: a failure injected on rank 1") != std::string::npos);
    // One line from formfactor, whatever mpirun adds about the exit code.
    const auto first = r.err.find("formfactor:");
    CHECK(r.err.find("formfactor:", first + 1) == std::string::npos);
    CHECK(r.seconds < 6.0);
    CHECK(dir.entries() == 0);
}

TEST_CASE("mpi: Ctrl-C on mpirun stops every rank within seconds and writes nothing" *
          doctest::test_suite("mpi")) {
    TempDir dir;
    // The run takes over 30 s; SIGINT goes to mpirun after 3 s, as Ctrl-C in a terminal.
    const std::string job =
        mpirun(2) + " " + shell_quote(FF_CLI_PATH) +
        " compute cornell --subdivide 16 --method analytic --threads 1 -o F.npy";
    const Run r = run_shell(dir, job + " & pid=$!; sleep 3; kill -INT $pid; wait $pid");
    INFO(said(r));
    CHECK(r.seconds < 3.0 + 5.0);
    CHECK(r.code != 0);
    // The ranks print "interrupted by"; mpirun forwards their stderr, but while it tears the
    // job down it may drop that line (seen in 2 runs of 3 once the job was in its first phase
    // at 3 s), so the line is not required.
    WARN(r.err.find("formfactor: interrupted by") != std::string::npos);
    CHECK(dir.entries() == 0);
}

TEST_CASE("mpi: a bad option on rank 0 ends every rank with one message" *
          doctest::test_suite("mpi")) {
    TempDir dir;
    const Run r = run(dir, 3, "compute cornell --method no-such-method -o F.npy");
    INFO(said(r));
    CHECK(r.code == 2);
    CHECK(r.err.rfind("formfactor: --method", 0) == 0);
    CHECK(r.seconds < 10.0);
    CHECK(dir.entries() == 0);
}

#endif
