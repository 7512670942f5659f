// Benchmark of sparse runs (formfactor/pipeline_sparse.h): the analytic method on the open city
// scene (formfactor/scene/city.h), rows computed in blocks by the pipeline and thresholded into
// CSR, never a dense N × N matrix. city-2 (129 patches) and city-4 (489) by default; larger
// ones on request, FF_BENCH_SPARSE_N=6,18,58 (city-6: 1,081 patches, ~25 min on the loaded
// 2-core machine; city-18: 9,505 and city-58: 97,905 take hours to days: see README.md).
// Threshold 1e-6, default tolerances. Reported: wall time, process CPU time (the machine is
// shared), peak RSS (of the whole process, cumulative across cases, which run smallest first),
// stored entries per row, blocks, the dropped mass, and the pair evaluations (every pair: no
// candidate culling yet, so time grows as N²).

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <ctime>
#include <string>

#include "bench_common.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/city.h"

using namespace formfactor;

using bench::process_cpu_seconds;

namespace {

void BM_SparseCity(benchmark::State& state) {
    const Scene scene = city_scene(static_cast<int>(state.range(0)));
    SparseOptions sparse;
    sparse.threshold = 1e-6;
    SparseComputeResult r;
    const double cpu0 = process_cpu_seconds();
    for (auto _ : state) r = compute_sparse_form_factors(scene, {}, sparse);
    const double n = static_cast<double>(scene.patches.size());
    state.counters["patches"] = n;
    state.counters["nonzeros_per_row"] = static_cast<double>(r.form_factors.nonzeros()) / n;
    state.counters["csr_MB"] = r.form_factors.memory_bytes() / 1e6;
    state.counters["blocks"] = static_cast<double>(r.run.blocks);
    state.counters["block_rows"] = static_cast<double>(r.run.block_rows);
    state.counters["peak_rss_MB"] = peak_memory_bytes() / 1e6;
    state.counters["cpu_s"] = process_cpu_seconds() - cpu0;
    state.counters["dropped_mass"] = r.diagnostics.dropped_area_weighted;
    state.counters["sky_mean"] = 1.0 - r.diagnostics.row_sum_mean;
    if (r.report.pairs) state.counters["pairs"] = static_cast<double>(r.report.pairs->pairs);
}

}  // namespace

BENCHMARK(BM_SparseCity)->Arg(2)->Arg(4)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

// Larger cities only on request (FF_BENCH_SPARSE_N, comma-separated N): every pair is evaluated.
static const bool kLarger =
    bench::register_sizes_from_env("BM_SparseCity", BM_SparseCity, "FF_BENCH_SPARSE_N");

BENCHMARK_MAIN();
