// The CLI's outputs on a fixed set of scenes, byte for byte, against the files the CLI wrote
// before the library was redesigned around its pipeline API (tests/data/golden/, written by the
// commit before that work). Reports are compared as JSON without what changes from run to run
// (times, the timestamp, rates). A deliberate change of numbers regenerates the files:
//   FF_GOLDEN_WRITE=1 build/formfactor_tests -ts=golden
// and says so in its commit.
//
// The reference machine has AVX-512. Embree traces rays with other kernels on other vector
// units, and a ray that grazes an edge can then hit where it missed: the ray-traced outputs of
// a machine without AVX-512 may differ in such samples. Where they do, the files of that
// machine kind stand in tests/data/golden-<isa>/ (only the files that differ; FF_GOLDEN_WRITE
// on such a machine writes there what differs from golden/, and golden/ itself only on the
// reference kind, or with FF_GOLDEN_WRITE=base for a change that no vector unit decides: the
// analytic method's outputs are the same on all).

#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/cli_runner.h"

using formfactor::testing::Cli;
using formfactor::testing::CliResult;
using formfactor::testing::shell_quote;

namespace fs = std::filesystem;

namespace {

struct GoldenCase {
    const char* name;
    const char* args;  ///< after `formfactor`; DATA is replaced by tests/data
    std::vector<const char*> files;
};

const char* const kThermal =
    "surface,emissivity,temperature\nx0,1,300\nx1,1,300\ny0,1,300\ny1,1,300\n"
    "z0,0.6,1000\nz1,1,300\n";
const char* const kPoints = "x,y,z,nx,ny,nz\n0.5,0.5,0.01,0,0,1\n0.2,0.7,0.3,1,0,0\n";

const std::vector<GoldenCase>& cases() {
    static const std::vector<GoldenCase> all = {
        {"cube_analytic",
         "compute cube --subdivide 2 -o F.csv --patches patches.csv --report report.json",
         {"F.csv", "patches.csv", "report.json"}},
        {"cornell_analytic",
         "compute cornell --subdivide 2 -o F.npy --report report.json",
         {"F.npy", "report.json"}},
        {"room_vs3_per_surface",
         "compute DATA/room-4-obstruction.vs3 -o F.txt --report report.json",
         {"F.txt", "report.json"}},
        {"cube_mc_hemisphere",
         "compute cube --subdivide 2 --method mc-hemisphere --samples 2000 -o F.npy --stderr "
         "se.npy --report report.json",
         {"F.npy", "se.npy", "report.json"}},
        {"cornell_mc_target",
         "compute cornell --subdivide 1 --method mc-target --samples 256 -o F.npy --stderr se.npy "
         "--report report.json",
         {"F.npy", "se.npy", "report.json"}},
        {"cube_mc_area",
         "compute cube --method mc-area --samples 512 -o F.csv --report report.json",
         {"F.csv", "report.json"}},
        {"cornell_hemicube",
         "compute cornell --method hemicube --resolution 64 -o F.csv --report report.json",
         {"F.csv", "report.json"}},
        {"cornell_hemiplane",
         "compute cornell --method hemiplane --resolution 64 -o F.csv --report report.json",
         {"F.csv", "report.json"}},
        {"cube_repair",
         "compute cube --subdivide 2 --method mc-area --samples 64 --repair both "
         "-o F.csv --report report.json",
         {"F.csv", "report.json"}},
        {"cornell_solve",
         "solve cornell --subdivide 2 -o B.csv --report report.json",
         {"B.csv", "report.json"}},
        {"cube_thermal",
         "solve cube --subdivide 2 --thermal --properties thermal.csv -o T.csv "
         "--exchange-factors X.csv --report report.json",
         {"T.csv", "X.csv", "report.json"}},
        {"cornell_run",
         "run cornell --subdivide 2 --image-size 48 --out-dir out",
         {"out/formfactors.npy", "out/patches.csv", "out/radiosity.csv", "out/cornell.png",
          "out/cornell.ply", "out/report.json"}},
        {"cornell_points", "point cornell --points points.csv -o P.csv", {"P.csv"}},
    };
    return all;
}

std::string read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// What differs between two runs of the same command: removed from reports before comparing.
// rechecked_segments counts the clear segments that pass within rounding of a triangle's edge:
// Embree's kernels of one vector unit put a few of them on either side on different CPUs (36 on
// an AMD EPYC, 37 on the reference machine, for the same matrix to the last bit).
void strip_volatile(nlohmann::json& j) {
    if (j.is_object()) {
        for (auto it = j.begin(); it != j.end();) {
            const std::string& k = it.key();
            if (k == "timestamp" || k == "timings" || k == "formfactor_version" ||
                k == "rechecked_segments" || k.find("seconds") != std::string::npos ||
                k.find("per_second") != std::string::npos || k == "peak_memory_bytes" ||
                k == "memory") {
                it = j.erase(it);
            } else {
                strip_volatile(*it);
                ++it;
            }
        }
    } else if (j.is_array()) {
        for (auto& e : j) strip_volatile(e);
    }
}

// Paths inside reports name the temporary working directory: reduce them to file names.
void strip_paths(nlohmann::json& j, const std::string& work) {
    if (j.is_string()) {
        std::string s = j.get<std::string>();
        for (std::size_t at; (at = s.find(work)) != std::string::npos;) s.erase(at, work.size());
        j = s;
    } else if (j.is_structured()) {
        for (auto& e : j) strip_paths(e, work);
    }
}

// The bytes of an output, or for a report its JSON without volatile fields and directories (the
// form the golden reports are stored in).
std::string normalised(const fs::path& file, const std::string& work, const std::string& data) {
    const std::string bytes = read_bytes(file);
    if (file.extension() != ".json") return bytes;
    nlohmann::json j = nlohmann::json::parse(bytes);
    strip_volatile(j);
    strip_paths(j, work);
    strip_paths(j, data);
    return j.dump(1);
}

// The vector unit Embree picks its kernels for: "" for the reference kind (AVX-512), else the
// suffix of the folder that holds this kind's differing files.
std::string isa_suffix() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl")) return "";
    if (__builtin_cpu_supports("avx2")) return "-avx2";
    return "-sse";
#else
    return "-other";
#endif
}

}  // namespace

TEST_CASE("golden: the CLI's outputs are those of the reference run") {
    const fs::path golden = fs::path(FF_TEST_DATA_DIR) / "golden";
    const std::string isa = isa_suffix();
    const fs::path golden_isa = fs::path(FF_TEST_DATA_DIR) / ("golden" + isa);
    MESSAGE("reference files: golden/" << (isa.empty() ? "" : ", then golden" + isa + "/"));
    const char* write_env = std::getenv("FF_GOLDEN_WRITE");
    const bool write = write_env != nullptr;
    const bool write_base = write && std::string(write_env) == "base";
    for (const GoldenCase& c : cases()) {
        const std::string name = c.name;
        CAPTURE(name);
        Cli cli;
        cli.write("thermal.csv", kThermal);
        cli.write("points.csv", kPoints);
        std::string args = c.args;
        for (std::size_t at; (at = args.find("DATA")) != std::string::npos;)
            args.replace(at, 4, shell_quote(FF_TEST_DATA_DIR));
        // One thread: the reference run is then the same however many cores the machine has.
        const CliResult r = cli.run(args + " --threads 1");
        INFO(r.err);
        REQUIRE(r.code == 0);
        for (const char* f : c.files) {
            const std::string file = f;
            CAPTURE(file);
            const fs::path got = cli.file(f);
            REQUIRE(fs::exists(got));
            const fs::path base_ref = golden / c.name / fs::path(f).filename();
            const fs::path isa_ref = golden_isa / c.name / fs::path(f).filename();
            const std::string work = cli.dir().path().string() + "/";
            const std::string text = normalised(got, work, std::string(FF_TEST_DATA_DIR) + "/");
            if (write) {
                // golden/ on the reference kind; elsewhere only what differs from it.
                const bool differs = !fs::exists(base_ref) || read_bytes(base_ref) != text;
                // (=base leaves the files that already have a variant of this kind to it.)
                const bool base = isa.empty() || (write_base && !fs::exists(isa_ref));
                const fs::path to = base ? base_ref : isa_ref;
                if (base || differs) {
                    fs::create_directories(to.parent_path());
                    std::ofstream(to, std::ios::binary) << text;
                } else if (fs::exists(isa_ref)) {
                    fs::remove(isa_ref);
                }
                continue;
            }
            const fs::path ref = !isa.empty() && fs::exists(isa_ref) ? isa_ref : base_ref;
            const std::string ref_name = ref.string();
            CAPTURE(ref_name);
            REQUIRE(fs::exists(ref));
            const bool same = text == read_bytes(ref);
            CHECK(same);
        }
    }
}
