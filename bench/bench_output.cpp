// Matrix writers: the exact form factors of `cube --subdivide 32` (N = 6,144, a third of the
// entries zero, the others 1e-7 … 1e-2) written to a temporary folder in each format through
// write_matrix (the atomic temporary-and-rename path the CLI uses), and the patch table.
// Figures: seconds per file and MB/s of output; BM_FormatMatrix: the same text into a stream
// that only counts bytes (the formatting alone, without the file system).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <ostream>
#include <streambuf>
#include <string>

#include "../tests/support/method_runner.h"
#include "../tests/support/temp_dir.h"
#include "formfactor/methods/method.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/scene/scene.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

const Scene& cube() {
    static const Scene s = [] {
        Scene c = load_scene("cube");
        subdivide(c, SubdivisionOptions{32, 0.0});
        return c;
    }();
    return s;
}

const FormFactors& matrix() {
    static const FormFactors ff = [] {
        MethodOptions o;
        nlohmann::json d;
        return run_method(*make_method("analytic"), cube(), o, d);
    }();
    return ff;
}

void report(benchmark::State& state, const std::string& path) {
    const auto bytes = static_cast<double>(std::filesystem::file_size(path));
    state.counters["MB"] = bytes / 1e6;
    state.counters["MB_per_s"] =
        benchmark::Counter(bytes, benchmark::Counter::kIsIterationInvariantRate);
    std::filesystem::remove(path);
}

void BM_WriteMatrix(benchmark::State& state, const std::string& ext) {
    const FormFactors& ff = matrix();
    const testing::TempDir dir;
    const std::string path = dir.file("F." + ext);
    for (auto _ : state) write_matrix(path, ff);
    report(state, path);
    state.counters["N"] = static_cast<double>(ff.size());
}

// A stream that only counts: the formatting cost without the file system's.
class CountingBuffer : public std::streambuf {
  public:
    std::size_t bytes = 0;

  protected:
    std::streamsize xsputn(const char*, std::streamsize n) override {
        bytes += static_cast<std::size_t>(n);
        return n;
    }
    int_type overflow(int_type c) override {
        if (c != traits_type::eof()) ++bytes;
        return c;
    }
};

void BM_FormatMatrix(benchmark::State& state, MatrixFormat format) {
    const FormFactors& ff = matrix();
    MatrixFileInfo info;
    info.areas = ff.areas;
    std::size_t bytes = 0;
    for (auto _ : state) {
        CountingBuffer sink;
        std::ostream out(&sink);
        write_matrix(out, format, ff.F, info);
        bytes = sink.bytes;
    }
    state.counters["MB"] = static_cast<double>(bytes) / 1e6;
    state.counters["MB_per_s"] = benchmark::Counter(static_cast<double>(bytes),
                                                    benchmark::Counter::kIsIterationInvariantRate);
}

void BM_WritePatchTable(benchmark::State& state) {
    const testing::TempDir dir;
    const std::string path = dir.file("patches.csv");
    for (auto _ : state) write_patch_table(path, cube());
    report(state, path);
}

}  // namespace

BENCHMARK_CAPTURE(BM_WriteMatrix, npy, std::string("npy"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_WriteMatrix, txt, std::string("txt"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_WriteMatrix, csv, std::string("csv"))
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_FormatMatrix, txt, MatrixFormat::View3dText)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_FormatMatrix, csv, MatrixFormat::Csv)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);
BENCHMARK(BM_WritePatchTable)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);

BENCHMARK_MAIN();
