// Monte-Carlo estimators: rays per second against the raw ray-tracer throughput measured in the
// same run on the same scene with the same kind of rays (incoherent segments for mc-area and
// mc-target, first-hit rays for mc-hemisphere), all cores. Then the Cornell box at ~10k patches
// with mc-hemisphere at 10⁴ rays per patch: time and the spread of the row sums (the box is open
// at the front, so rows sum to less than 1).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>

#include "../tests/support/method_runner.h"
#include "bench_common.h"
#include "formfactor/methods/method.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

const Scene& scene() {
    static const Scene s = bench::cornell(6);  // 720 patches, 1368 triangles
    return s;
}

// Raw throughput, set by the raw benchmarks: rays per wall-clock second and per CPU second of
// the whole process (all threads). The machine is shared, so the CPU-time figures are the fair
// comparison: other processes' load changes wall-clock rates between benchmarks.
double raw_occlusion = 0, raw_first_hit = 0;
double raw_occlusion_cpu = 0, raw_first_hit_cpu = 0;

double process_cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void BM_RawOcclusion(benchmark::State& state) {
    const auto q = bench::random_segments(scene(), 1 << 18);
    auto v = make_visibility(scene());
    std::vector<std::uint8_t> out;
    std::size_t rays = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_seconds();
    for (auto _ : state) rays += bench::cast_occlusion(*v, q, out, 0);
    raw_occlusion =
        rays / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    raw_occlusion_cpu = rays / (process_cpu_seconds() - c0);
    state.counters["rays_per_cpu_s"] = raw_occlusion_cpu;
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}

// The same, with the segments in runs of 16 per patch pair as mc-target casts them (coherent:
// cheaper for the ray tracer). Reported beside the incoherent rate, not used for the fractions.
void BM_RawOcclusionPairs(benchmark::State& state) {
    const auto q = bench::pair_segments(scene(), 1 << 18, 16);
    auto v = make_visibility(scene());
    std::vector<std::uint8_t> out;
    std::size_t rays = 0;
    const double c0 = process_cpu_seconds();
    for (auto _ : state) rays += bench::cast_occlusion(*v, q, out, 0);
    state.counters["rays_per_cpu_s"] = rays / (process_cpu_seconds() - c0);
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}

void BM_RawFirstHit(benchmark::State& state) {
    const auto q = bench::random_rays(scene(), 1 << 18);
    auto v = make_visibility(scene());
    std::vector<RayHit> out;
    std::size_t rays = 0;
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_seconds();
    for (auto _ : state) rays += bench::cast_rays(*v, q, out, 0);
    raw_first_hit =
        rays / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    raw_first_hit_cpu = rays / (process_cpu_seconds() - c0);
    state.counters["rays_per_cpu_s"] = raw_first_hit_cpu;
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
}

void bench_method(benchmark::State& state, const std::string& method, std::uint64_t samples,
                  double raw, double raw_cpu) {
    MethodOptions o;
    o.samples = samples;
    std::uint64_t rays = 0, pair_rays = 0;
    double seconds = 0, se_max = 0, se_mean = 0, cpu = 0, ray_pass_cpu = 0;
    for (auto _ : state) {
        nlohmann::json d;
        const double c0 = process_cpu_seconds();
        benchmark::DoNotOptimize(run_method(*make_method(method), scene(), o, d));
        cpu += process_cpu_seconds() - c0;
        rays += d["rays_cast"].get<std::uint64_t>();
        seconds += d["seconds"].get<double>();
        se_max = d["standard_error_max"].get<double>();
        se_mean = d["standard_error_mean"].get<double>();
        if (d.contains("phases")) {
            // mc-target: the CPU of its ray pass alone, and the rays its pairs stand for
            // (samples per pair, also for the pairs that the shaft test settled without rays).
            ray_pass_cpu += d["phases"]["rays"]["process_cpu_seconds"].get<double>();
            pair_rays += d["pairs"].get<std::uint64_t>() * samples;
        }
    }
    if (ray_pass_cpu > 0) {
        state.counters["ray_pass_fraction_of_raw_cpu"] =
            raw_cpu > 0 ? rays / ray_pass_cpu / raw_cpu : 0.0;
        state.counters["pair_rays_per_cpu_s"] = pair_rays / cpu;
        state.counters["pair_rays_fraction_of_raw_cpu"] =
            raw_cpu > 0 ? pair_rays / cpu / raw_cpu : 0.0;
    }
    state.counters["cpu_s"] = cpu;
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
    state.counters["rays_per_s"] = rays / seconds;
    state.counters["fraction_of_raw"] = raw > 0 ? rays / seconds / raw : 0.0;
    state.counters["rays_per_cpu_s"] = rays / cpu;
    state.counters["fraction_of_raw_cpu"] = raw_cpu > 0 ? rays / cpu / raw_cpu : 0.0;
    state.counters["se_max"] = se_max;
    state.counters["se_mean"] = se_mean;
}

void BM_McArea(benchmark::State& state) {
    bench_method(state, "mc-area", 16, raw_occlusion, raw_occlusion_cpu);
}
void BM_McHemisphere(benchmark::State& state) {
    bench_method(state, "mc-hemisphere", 10000, raw_first_hit, raw_first_hit_cpu);
}
void BM_McTarget(benchmark::State& state) {
    bench_method(state, "mc-target", 16, raw_occlusion, raw_occlusion_cpu);
}

// Cornell box (with blocks) at 22×22 per surface = 9680 patches, 10⁴ rays per patch.
void BM_Cornell10kHemisphere(benchmark::State& state) {
    const Scene s = bench::cornell(22);
    MethodOptions o;
    o.samples = 10000;
    for (auto _ : state) {
        nlohmann::json d;
        const double c0 = process_cpu_seconds();
        const FormFactors ff = run_method(*make_method("mc-hemisphere"), s, o, d);
        const double cpu = process_cpu_seconds() - c0;
        state.counters["fraction_of_raw_cpu"] =
            raw_first_hit_cpu > 0 ? d["rays_cast"].get<double>() / cpu / raw_first_hit_cpu : 0.0;
        const Eigen::VectorXd rows = ff.F.rowwise().sum();
        double rs_se = 0;
        for (Eigen::Index i = 0; i < ff.F.rows(); ++i)
            rs_se = std::max(rs_se, std::sqrt(ff.standard_error->row(i).squaredNorm()));
        state.counters["patches"] = static_cast<double>(s.patches.size());
        state.counters["rays_per_s"] = d["rays_per_second"].get<double>();
        state.counters["fraction_of_raw"] =
            raw_first_hit > 0 ? d["rays_per_second"].get<double>() / raw_first_hit : 0.0;
        state.counters["row_sum_min"] = rows.minCoeff();
        state.counters["row_sum_max"] = rows.maxCoeff();
        state.counters["row_sum_mean"] = rows.mean();
        state.counters["row_sum_sd"] =
            std::sqrt((rows.array() - rows.mean()).square().sum() / double(rows.size() - 1));
        state.counters["escaped"] = d["escaped_fraction"].get<double>();
        state.counters["se_max"] = d["standard_error_max"].get<double>();
        state.counters["row_se_max"] = rs_se;
    }
}

}  // namespace

BENCHMARK(BM_RawOcclusion)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_RawOcclusionPairs)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_RawFirstHit)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_McArea)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_McHemisphere)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_McTarget)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_Cornell10kHemisphere)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

BENCHMARK_MAIN();
