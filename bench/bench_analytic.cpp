// Benchmark of the analytic method: the full matrix of the built-in unit cube with each face
// split 32 × 32 (6,144 patches, facing inward), and the accuracy of its far-field path against the
// exact contour integral on a random sample of pairs.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "../tests/support/method_runner.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"
#include "kernels/analytic_internal.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

// The built-in unit cube (faces inward), each face split n × n: what `formfactor compute cube
// --subdivide n` computes.
Scene cube_scene(int n) {
    Scene s = load_scene("cube");
    SubdivisionOptions sub;
    sub.n = n;
    subdivide(s, sub);
    return s;
}

void BM_CubeFullMatrix(benchmark::State& state) {
    const Scene scene = cube_scene(static_cast<int>(state.range(0)));
    const auto method = make_method("analytic");
    MethodOptions opt;
    opt.threads = static_cast<int>(state.range(1));
    opt.tolerance = std::pow(10.0, -static_cast<double>(state.range(3)));
    nlohmann::json details;
    std::unique_ptr<FormFactors> result;
    for (auto _ : state) {
        details = nlohmann::json::object();
        result = std::make_unique<FormFactors>(run_method(*method, scene, opt, details));
        benchmark::DoNotOptimize(result->F.data());
    }
    const FormFactors& ff = *result;
    const double n = static_cast<double>(scene.patches.size());
    state.counters["patches"] = n;
    state.counters["tolerance"] = opt.tolerance;
    state.counters["pairs/s"] =
        benchmark::Counter(n * (n - 1) / 2, benchmark::Counter::kIsIterationInvariantRate);
    state.counters["far"] = details["pairs_far_field"].get<double>();
    state.counters["exact"] = details["pairs_exact"].get<double>();
    state.counters["evals/far"] = details["far_field_kernel_evaluations"].get<double>() /
                                  std::max(1.0, details["pairs_far_field"].get<double>());
    // Accuracy: a random sample of pairs against the exact contour integral.
    std::mt19937_64 rng(12345);
    std::uniform_int_distribution<std::size_t> pick(0, scene.patches.size() - 1);
    double max_err = 0.0, max_row_defect = 0.0;
    const int samples = static_cast<int>(state.range(2));
    for (int s = 0; s < samples; ++s) {
        const std::size_t i = pick(rng), j = pick(rng);
        if (i == j) continue;
        const double exact = detail::polygon_to_polygon_contour(scene.patches[i].polygon,
                                                                scene.patches[j].polygon, false);
        max_err = std::max(
            max_err,
            std::abs(ff.F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) - exact));
    }
    for (Eigen::Index i = 0; i < ff.F.rows(); ++i)
        max_row_defect = std::max(max_row_defect, std::abs(ff.F.row(i).sum() - 1.0));
    state.counters["max_err_sample"] = max_err;
    state.counters["max_row_sum_defect"] = max_row_defect;
    std::fprintf(stderr, "details: %s\n", details.dump().c_str());
}

}  // namespace

// Args: faces split n × n, threads (0 = all), pairs checked against the exact path, and the
// tolerance per entry as a power of ten (1e-10 is the method's default; the target is
// ≤ 1e-9 per entry).
BENCHMARK(BM_CubeFullMatrix)
    ->Args({8, 0, 20000, 10})
    ->Args({32, 0, 100000, 10})
    ->Args({32, 0, 100000, 9})
    ->Args({32, 1, 0, 10})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

BENCHMARK_MAIN();
