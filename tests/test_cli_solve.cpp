// End-to-end tests of `formfactor solve` and `formfactor render`.

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <stb/stb_image.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "formfactor/output/matrix_io.h"
#include "formfactor/output/solution_io.h"
#include "support/cli_runner.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::read_text;
using formfactor::testing::write_text;

namespace {

std::string describe(const CliResult& r) {
    return "exit " + std::to_string(r.code) + "\nstdout: " + r.out + "\nstderr: " + r.err;
}

constexpr double kSigma = 5.670374419e-8;

}  // namespace

TEST_CASE(
    "cli solve: radiosity of the closed cube with a light, every solver, "
    "a report") {
    Cli cli;
    // Face z0 (patches 64..79 with --subdivide 4) emits; uniform ρ = 0.5 from the
    // material.
    write_text(cli.file("p.csv"), "surface,emission_r,emission_g,emission_b\nz0,1,2,3\n");
    CliResult r = cli.run(
        "solve cube --subdivide 4 --properties p.csv --solver "
        "direct -o ref.csv --report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("solve      radiosity, direct") != std::string::npos);
    const SolutionTable ref = read_solution_csv(cli.file("ref.csv"), 96);
    // Closed enclosure, uniform ρ: Σ A_i B_i (1 − ρ) = Σ A_i E_i, so the mean
    // radiosity is E_total / (A_total (1 − ρ)) = (1 · 1) / (6 · 0.5) per unit of
    // emission.
    double mean = 0.0;
    for (const auto& b : ref.radiosity) mean += b[0] / 96.0;
    CHECK(mean == doctest::Approx(1.0 / 3.0).epsilon(1e-9));
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["command"] == "solve");
    CHECK(report["solve"]["kind"] == "radiosity");
    CHECK(report["solve"]["solver"]["converged"] == true);
    CHECK(report["solve"]["energy_balance"]["relative_defect"].get<double>() < 1e-9);
    for (const char* s : {"jacobi", "gauss-seidel", "shooting"}) {
        r = cli.run(std::string("solve cube --subdivide 4 --properties p.csv --residual 1e-12 ") +
                    "--solver " + s + " -o b.csv");
        INFO(describe(r));
        REQUIRE(r.code == 0);
        const SolutionTable t = read_solution_csv(cli.file("b.csv"), 96);
        for (std::size_t i = 0; i < 96; ++i)
            CHECK((t.radiosity[i] - ref.radiosity[i]).cwiseAbs().maxCoeff() < 1e-10);
    }
}

TEST_CASE(
    "cli solve: thermal two-surface enclosure from the cube, exchange "
    "factors") {
    Cli cli;
    // Face z0 at 1000 K, ε = 0.6; the five others black at 300 K: q = ε σ (T1⁴ −
    // T2⁴).
    write_text(cli.file("p.csv"),
               "surface,emissivity,temperature\nx0,1,300\nx1,1,300\ny0,1,300\ny1,1,300\n"
               "z0,0.6,1000\nz1,1,300\n");
    CliResult r = cli.run(
        "solve cube --subdivide 2 --thermal --properties p.csv "
        "-o t.csv --exchange-factors X.csv "
        "--report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const SolutionTable t = read_solution_csv(cli.file("t.csv"), 24);
    REQUIRE(t.thermal);
    const double q = 0.6 * kSigma * (std::pow(1000.0, 4) - std::pow(300.0, 4));
    for (std::size_t i = 16; i < 20; ++i) CHECK(t.net_flux[i] == doctest::Approx(q).epsilon(1e-9));
    double total = 0.0;
    for (double p : t.net_power) total += p;
    CHECK(std::abs(total) < 1e-9 * q);
    const std::string text = read_text(cli.file("t.csv"));
    CHECK(text.substr(0, text.find('\n')) ==
          "patch,area,emissivity,temperature,radiosity,net_flux,net_power");
    const DenseMatrix X = read_matrix(cli.file("X.csv"));
    REQUIRE(X.rows() == 24);
    CHECK(X.row(16).sum() == doctest::Approx(0.6).epsilon(1e-9));  // Σ_j 𝓕_ij = ε_i (closed)
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["solve"]["kind"] == "thermal");
    CHECK(std::abs(report["solve"]["energy_balance"]["total_net_power_W"].get<double>()) <
          1e-9 * q);
}

TEST_CASE("cli solve: repair, and the errors") {
    Cli cli;
    CliResult r = cli.run("solve cube --subdivide 3 --repair both -o a.csv --report r.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("repair     both") != std::string::npos);
    const auto report = nlohmann::json::parse(read_text(cli.file("r.json")));
    CHECK(report["repair"]["mode"] == "both");
    CHECK(std::abs(report["repair"]["after"]["row_sum_max"].get<double>() - 1.0) < 1e-12);

    r = cli.run("solve plates --repair closure -o b.csv");
    CHECK(r.code == 2);
    CHECK(r.err.find("--repair: the scene is open") != std::string::npos);
    // The library names its options; the CLI shows them as flags.
    CHECK(r.err.find("use --repair reciprocity, or --force-closure if") != std::string::npos);
    CHECK(r.err.find('`') == std::string::npos);
    r = cli.run("solve cube --solver sor -o b.csv");
    CHECK(r.code == 2);
    CHECK(r.err.find("--solver: unknown solver 'sor'") != std::string::npos);
    write_text(cli.file("bad.csv"), "patch,emissivity\n0,2\n");
    r = cli.run("solve cube --thermal --properties bad.csv -o b.csv");
    CHECK(r.code == 1);
    CHECK(r.err.find("bad.csv:2: emissivity = 2 must be in (0, 1]") != std::string::npos);
    r = cli.run(
        "solve cube --solver jacobi --max-iterations 2 --properties "
        "p.csv -o b.csv");
    CHECK(r.code == 1);
    write_text(cli.file("light.csv"), "patch,emission_r\n0,1\n");
    r = cli.run(
        "solve cube --solver jacobi --max-iterations 2 --properties "
        "light.csv -o b.csv");
    CHECK(r.code == 1);
    CHECK(r.err.find("did not converge in 2 sweeps") != std::string::npos);
    // The library names its options; the CLI shows them as flags.
    CHECK(r.err.find("raise --max-iterations, loosen --residual or use --solver direct") !=
          std::string::npos);
    r = cli.run(
        "solve cube --solver jacobi --max-iterations 2 --properties "
        "light.csv -o b.csv "
        "--allow-unconverged");
    CHECK(r.code == 0);
    CHECK(r.err.find("warning: solve: jacobi did not converge") != std::string::npos);
    r = cli.run("compute cube -o F.npy");
    REQUIRE(r.code == 0);
    r = cli.run("solve cube --subdivide 2 --matrix F.npy -o c.csv");
    CHECK(r.code == 1);
    CHECK(r.err.find("F.npy: a 6x6 matrix, the scene has 24 patches") != std::string::npos);
    r = cli.run("solve cube --matrix F.npy --properties light.csv -o c.csv");
    CHECK(r.code == 0);
    CHECK(r.out.find("F from matrix file") != std::string::npos);
}

TEST_CASE("cli render: PNG of a solution, false colour, meshes") {
    Cli cli;
    CliResult r = cli.run("solve cornell-empty --subdivide 6 -o b.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    r = cli.run(
        "render cornell-empty --subdivide 6 --radiosity b.csv --size 96 "
        "72 -o c.png");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    int w = 0, h = 0, n = 0;
    unsigned char* img = stbi_load(cli.file("c.png").c_str(), &w, &h, &n, 3);
    REQUIRE(img != nullptr);
    CHECK(w == 96);
    CHECK(h == 72);
    // The published camera: the red wall on the left, the green one on the right.
    const unsigned char* left = img + 3 * (36 * 96 + 14);
    const unsigned char* right = img + 3 * (36 * 96 + 81);
    CHECK(left[0] > left[1] + 40);
    CHECK(right[1] > right[0] + 20);
    stbi_image_free(img);
    r = cli.run("render cornell-empty --subdivide 6 --radiosity b.csv -o c.ply");
    CHECK(r.code == 0);
    CHECK(read_text(cli.file("c.ply")).substr(0, 4) == "ply\n");
    r = cli.run("render cornell-empty --subdivide 6 --radiosity b.csv -o c.gltf");
    CHECK(r.code == 0);
    CHECK(nlohmann::json::parse(read_text(cli.file("c.gltf")))["asset"]["version"] == "2.0");
    r = cli.run("compute cornell-empty --subdivide 6 -o F.npy");
    REQUIRE(r.code == 0);
    r = cli.run(
        "render cornell-empty --subdivide 6 --false-colour row --row 5 "
        "--matrix F.npy --size 120 "
        "80 -o row.png");
    CHECK(r.code == 0);
    CHECK(r.out.find("F from patch 5") != std::string::npos);
    // Errors.
    r = cli.run(
        "render cornell-empty --subdivide 6 --radiosity b.csv "
        "--false-colour temperature "
        "-o t.png");
    CHECK(r.code == 2);
    CHECK(r.err.find("needs a thermal result table") != std::string::npos);
    r = cli.run("render cornell-empty --radiosity b.csv -o c.png");
    CHECK(r.code == 1);
    CHECK(r.err.find("the scene has 10") != std::string::npos);
    r = cli.run("render cornell-empty --radiosity b.csv -o c.bmp");
    CHECK(r.code == 2);
    r = cli.run("render cornell-empty -o c.png");
    CHECK(r.code == 2);
    CHECK(r.err.find("--radiosity") != std::string::npos);
}

TEST_CASE("cli solve --storage hierarchical: the thermal and radiosity solves of the dense path") {
    Cli cli;
    // A closed cube, 6 × 12 × 12 = 864 patches: z0 hot, z1 cold, the rest adiabatic.
    write_text(cli.file("p.csv"),
               "surface,emissivity,temperature,net_flux,emission_r,emission_g,emission_b\n"
               "z0,0.8,1000,,1,2,3\nz1,0.3,300,,,,\nx0,0.5,,0,,,\nx1,0.5,,0,,,\n"
               "y0,0.2,,0,,,\ny1,0.9,,0,,,\n");
    const std::string base = "solve cube --subdivide 12 --properties p.csv ";
    CliResult r = cli.run(base + "--thermal -o dense.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    r = cli.run(base + "--thermal --storage hierarchical -o h.csv --report h.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("operator   hierarchical, error target 1e-06") != std::string::npos);
    CHECK(r.out.find("solve      thermal, gmres") != std::string::npos);
    const SolutionTable d = read_solution_csv(cli.file("dense.csv"), 864);
    const SolutionTable h = read_solution_csv(cli.file("h.csv"), 864);
    REQUIRE(h.thermal);
    double total = 0.0;
    for (double q : d.net_power) total += std::abs(q);
    for (std::size_t i = 0; i < 864; ++i) {
        CHECK(std::abs(h.radiosity[i][0] - d.radiosity[i][0]) <= 1e-5 * d.radiosity[i][0]);
        CHECK(std::abs(h.net_power[i] - d.net_power[i]) <= 1e-5 * total);
    }
    const auto report = nlohmann::json::parse(read_text(cli.file("h.json")));
    CHECK(report["storage"]["kind"] == "hierarchical");
    CHECK(report["details"]["hierarchical"]["low_rank_blocks"].get<int>() > 0);
    CHECK(report["memory"]["peak_bytes"].get<double>() > 0);
    CHECK(report["solve"]["solver"]["converged"] == true);
    CHECK(std::abs(report["diagnostics"]["row_sum"]["min"].get<double>() - 1.0) < 1e-5);

    // Radiosity (RGB) with gmres and jacobi on the operator, against the dense direct solve.
    r = cli.run(base + "--solver direct --residual 1e-12 -o rd.csv");
    REQUIRE(r.code == 0);
    const SolutionTable rd = read_solution_csv(cli.file("rd.csv"), 864);
    for (const char* s : {"gmres", "jacobi"}) {
        r = cli.run(base + "--storage hierarchical --residual 1e-10 --solver " + s + " -o rh.csv");
        INFO(describe(r));
        REQUIRE(r.code == 0);
        const SolutionTable rh = read_solution_csv(cli.file("rh.csv"), 864);
        for (std::size_t i = 0; i < 864; ++i)
            for (int c = 0; c < 3; ++c)
                CHECK(std::abs(rh.radiosity[i][c] - rd.radiosity[i][c]) <=
                      1e-5 * rd.radiosity[i][c] + 1e-12);
    }
}

TEST_CASE("cli solve --storage hierarchical: what it refuses, with the option named") {
    Cli cli;
    struct Case {
        const char* args;
        const char* says;
    };
    for (const Case& c : {
             Case{"solve cube --subdivide 4 --storage tiles -o r.csv", "--storage"},
             Case{"solve cube --subdivide 4 --storage hierarchical --solver direct -o r.csv",
                  "--solver"},
             Case{"solve cube --subdivide 4 --storage hierarchical --repair both -o r.csv",
                  "--repair"},
             Case{"solve cube --subdivide 4 --storage hierarchical --error-target 0 -o r.csv",
                  "--error-target"},
             Case{"solve cube --subdivide 4 --storage hierarchical --exchange-factors X.csv "
                  "-o r.csv",
                  "--exchange-factors"},
             Case{"solve cornell --storage hierarchical -o r.csv", "obstructions"},
             Case{"solve cornell --storage hierarchical -o r.csv", "Use --storage dense or sparse"},
         }) {
        const CliResult r = cli.run(c.args);
        INFO(c.args << "\n" << describe(r));
        CHECK(r.code != 0);
        CHECK(r.err.find(c.says) != std::string::npos);
        CHECK_FALSE(std::filesystem::exists(cli.file("r.csv")));
    }
}

TEST_CASE("cli solve --storage auto: the hierarchical operator for a large unobstructed scene") {
    // 6 × 53² = 16,854 patches (> 16,384): auto takes the operator and says why; a small scene
    // and any option that needs F's entries keep the dense F.
    Cli cli;
    write_text(cli.file("p.csv"),
               "surface,emissivity,temperature,net_flux\nz0,0.8,1000,\nz1,0.3,300,\n"
               "x0,0.5,,0\nx1,0.5,,0\ny0,0.2,,0\ny1,0.9,,0\n");
    CliResult r =
        cli.run("solve cube --subdivide 53 --thermal --properties p.csv -o h.csv --report h.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("storage    hierarchical (auto: 16,854 patches without obstructions") !=
          std::string::npos);
    const auto report = nlohmann::json::parse(read_text(cli.file("h.json")));
    CHECK(report["storage"]["kind"] == "hierarchical");
    CHECK(report["storage"]["why"].get<std::string>().rfind("auto: ", 0) == 0);
    CHECK(report["solve"]["solver"]["converged"] == true);
    const SolutionTable h = read_solution_csv(cli.file("h.csv"), 16854);
    CHECK(h.thermal);

    r = cli.run("solve cube --subdivide 4 --thermal --properties p.csv -o d.csv --report d.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("hierarchical") == std::string::npos);
    const auto dense = nlohmann::json::parse(read_text(cli.file("d.json")));
    CHECK(dense["method"] == "analytic");
    CHECK(cli.run("solve cube --subdivide 4 --storage auto --error-target 0 -o r.csv").code == 2);
}

TEST_CASE("cli solve --storage sparse: the dense path's solutions from CSR, and what it refuses") {
    Cli cli;
    // The Cornell box with its blocks, 2 × 2 per surface: radiosity with
    // every solver the sparse storage has, against the dense direct solve.
    // mc-hemisphere rows (cheap under the sanitizers): every run of the same seed has the same F.
    const std::string base = "solve cornell --subdivide 2 --method mc-hemisphere --samples 400 ";
    CliResult r = cli.run(base + "--solver direct --residual 1e-12 -o d.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const std::size_t n = 80;  // 20 surfaces of the published box, 2 × 2 patches each
    const SolutionTable d = read_solution_csv(cli.file("d.csv"), n);
    for (const char* s : {"gauss-seidel", "gmres", "jacobi"}) {
        r = cli.run(base + "--storage sparse --residual 1e-11 --report s.json -o s.csv --solver " +
                    s);
        INFO(describe(r));
        REQUIRE(r.code == 0);
        CHECK(r.out.find("storage    sparse (asked for); threshold 0") != std::string::npos);
        const SolutionTable t = read_solution_csv(cli.file("s.csv"), n);
        // The residual is relative to ‖B‖∞: ‖B − B*‖∞ ≤ 1e-11 ‖B‖∞ / (1 − ρ_max) (ρ ≤ 0.8 in
        // the box), plus the direct solve's 1e-12.
        for (int c = 0; c < 3; ++c) {
            double bmax = 0.0;
            for (std::size_t i = 0; i < n; ++i) bmax = std::max(bmax, d.radiosity[i][c]);
            for (std::size_t i = 0; i < n; ++i)
                CHECK(std::abs(t.radiosity[i][c] - d.radiosity[i][c]) <= 6e-11 * bmax);
        }
        const auto report = nlohmann::json::parse(read_text(cli.file("s.json")));
        CHECK(report["storage"]["kind"] == "sparse");
        CHECK(report["options"]["solver"] == s);
        CHECK(report["memory"]["peak_bytes"].get<double>() > 0);
        CHECK(report["solve"]["solver"]["converged"] == true);
    }
    // A threshold in the closed cube (z0 hot, z1 cold, the rest adiabatic): without a repair the
    // dropped mass is said; the conservative closure makes F reciprocal and closed again, so the
    // energy balance holds.
    write_text(cli.file("p.csv"),
               "surface,emissivity,temperature,net_flux\nz0,0.8,1000,\nz1,0.3,300,\n"
               "x0,0.5,,0\nx1,0.5,,0\ny0,0.2,,0\ny1,0.9,,0\n");
    const std::string cube = "solve cube --subdivide 4 --thermal --properties p.csv ";
    r = cli.run(cube + "--threshold 1e-3 -o t.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("storage    sparse (auto: --threshold given)") != std::string::npos);
    CHECK(r.err.find("dropped mass") != std::string::npos);
    // The warnings name the options by their flags, as the library's backquoted names become.
    CHECK(r.err.find("in a closed scene --repair closure or both puts it back") !=
          std::string::npos);
    CHECK(r.err.find('`') == std::string::npos);
    r = cli.run(cube + "--storage sparse --threshold 1e-3 --repair both -o t.csv --report t.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.err.find("dropped mass") == std::string::npos);
    const auto report = nlohmann::json::parse(read_text(cli.file("t.json")));
    CHECK(report["repair"]["closure"] == true);
    CHECK(report["solve"]["energy_balance"]["relative_defect"].get<double>() < 1e-9);

    struct Case {
        const char* args;
        const char* says;
    };
    for (const Case& c : {
             Case{"solve cube --storage sparse --solver direct -o r.csv", "--solver"},
             Case{"solve cube --storage sparse --solver shooting -o r.csv", "--solver"},
             Case{"solve cube --storage sparse --exchange-factors X.csv -o r.csv",
                  "--exchange-factors"},
             Case{"solve cube --storage dense --threshold 1e-4 -o r.csv", "--threshold"},
             Case{"solve cube --storage sparse --threshold -1 -o r.csv", "--threshold"},
             Case{"solve cube --storage sparse --threshold nan -o r.csv", "--threshold"},
         }) {
        const CliResult e = cli.run(c.args);
        INFO(c.args << "\n" << describe(e));
        CHECK(e.code == 2);
        CHECK(e.err.find(c.says) != std::string::npos);
        CHECK_FALSE(std::filesystem::exists(cli.file("r.csv")));
    }
}

TEST_CASE("cli solve --storage auto: sparse storage for a large scene the operator cannot take") {
    // city-24: 16,849 patches (> 16,384), open, with obstructions (the buildings), F from
    // mc-hemisphere: auto computes F in CSR form and solves the thermal problem on it (GMRES).
    Cli cli;
    const std::size_t n = 16849;
    std::string p = "patch,emissivity,temperature\n";
    for (std::size_t i = 0; i < n; ++i)
        p += fmt::format("{},{},{}\n", i, 0.5 + 0.05 * double(i % 9), 280 + int(i % 37));
    write_text(cli.file("p.csv"), p);
    CliResult r = cli.run(
        "solve city-24 --method mc-hemisphere --samples 64 --threads 2 --thermal "
        "--ambient-temperature 260 --properties p.csv --repair reciprocity -o t.csv "
        "--report t.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    CHECK(r.out.find("storage    sparse (auto: 16,849 patches, the dense run would need") !=
          std::string::npos);
    CHECK(r.out.find("solve      thermal, gmres") != std::string::npos);
    const auto report = nlohmann::json::parse(read_text(cli.file("t.json")));
    CHECK(report["storage"]["kind"] == "sparse");
    CHECK(report["storage"]["nonzeros"].get<double>() < 0.01 * double(n) * double(n));
    CHECK(report["solve"]["solver"]["converged"] == true);
    const SolutionTable t = read_solution_csv(cli.file("t.csv"), n);
    REQUIRE(t.thermal);
    // Open to a 260 K sky, every patch at 280–316 K: the hottest patches lose heat, and what
    // the patches lose together goes to the sky (the balance holds: the repaired F is
    // reciprocal; Monte-Carlo rows alone are reciprocal only to their noise).
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        if (i % 37 == 36) CHECK(t.net_flux[i] > 0.0);
        total += t.net_power[i];
    }
    CHECK(report["repair"]["after"]["max_reciprocity_defect"].get<double>() < 1e-12);
    CHECK(report["solve"]["energy_balance"]["relative_defect"].get<double>() < 1e-8);
    CHECK(total > 0.0);
}

TEST_CASE("cli solve --matrix F.mtx|F.h5: the sparse F that compute wrote, solved as computed") {
    Cli cli;
    std::string p = "patch,emissivity,temperature\n";
    for (int i = 0; i < 129; ++i)
        p += fmt::format("{},{},{}\n", i, 0.6 + 0.03 * (i % 10), 270 + i % 41);
    write_text(cli.file("p.csv"), p);
    // mc-hemisphere (cheap under the sanitizers; its .h5 holds standard errors too): the same
    // seed gives the same F in every run.
    const std::string method = "--method mc-hemisphere --samples 256 ";
    for (const char* f : {"F.h5", "F.mtx"}) {
        const CliResult c =
            cli.run("compute city-2 " + method + "--threshold 1e-6 -o " + std::string(f));
        INFO(describe(c));
        REQUIRE(c.code == 0);
    }
    const std::string base = "solve city-2 --thermal --properties p.csv --ambient-temperature 250 ";
    CliResult r = cli.run(base + method + "--storage sparse --threshold 1e-6 -o ref.csv");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const std::string ref = read_text(cli.file("ref.csv"));
    for (const char* f : {"F.h5", "F.mtx"}) {
        r = cli.run(base + "--matrix " + f + " -o t.csv --report t.json");
        INFO(describe(r));
        REQUIRE(r.code == 0);
        CHECK(r.out.find(std::string("storage    sparse (read from ") + f + ")") !=
              std::string::npos);
        CHECK(read_text(cli.file("t.csv")) == ref);  // the same entries, bit for bit
        const auto report = nlohmann::json::parse(read_text(cli.file("t.json")));
        CHECK(report["method"] == "matrix file");
        CHECK(report["options"]["matrix"] == f);
    }
    struct Case {
        const char* args;
        int code;
        const char* says;
    };
    for (const Case& c : {
             Case{"solve city-4 --matrix F.h5 -o r.csv", 1, "same scene"},
             Case{"solve city-4 --matrix F.mtx -o r.csv", 1, "same scene"},
             Case{"solve city-2 --matrix F.mtx --storage dense -o r.csv", 2, "--matrix"},
             Case{"solve city-2 --matrix F.mtx --threshold 1e-3 -o r.csv", 2, "--threshold"},
             Case{"solve city-2 --matrix F.mtx --solver direct -o r.csv", 2, "--solver"},
             Case{"solve city-2 --matrix missing.mtx -o r.csv", 1, "missing.mtx"},
             Case{"solve city-2 --matrix F.h5 --repair closure -o r.csv", 2, "closure"},
         }) {
        const CliResult e = cli.run(c.args);
        INFO(c.args << "\n" << describe(e));
        CHECK(e.code == c.code);
        CHECK(e.err.find(c.says) != std::string::npos);
        CHECK_FALSE(std::filesystem::exists(cli.file("r.csv")));
    }
    // Reciprocity repair of the read F (an open scene: rows never raised).
    r = cli.run(base + "--matrix F.h5 --repair reciprocity -o t.csv --report t.json");
    INFO(describe(r));
    REQUIRE(r.code == 0);
    const auto report = nlohmann::json::parse(read_text(cli.file("t.json")));
    CHECK(report["repair"]["after"]["max_reciprocity_defect"].get<double>() < 1e-12);
    CHECK(report["repair"]["max_row_increase"].get<double>() <= 1e-15);
}
