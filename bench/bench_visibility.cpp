// Raw ray-tracer throughput through the Visibility interface: incoherent occlusion segments and
// first-hit rays in the subdivided Cornell box, per batching mode (single rays, 16-wide packets,
// the rtcOccluded1M stream), on all cores. items_per_second = rays per second.
#include <benchmark/benchmark.h>

#include "bench_common.h"

using namespace formfactor;

namespace {

struct Fixture {
    Scene scene;
    std::vector<SegmentQuery> segments;
    std::vector<RayQuery> rays;
    explicit Fixture(int n) : scene(bench::cornell(n)) {
        segments = bench::random_segments(scene, 1 << 18);
        rays = bench::random_rays(scene, 1 << 18);
    }
};

const Fixture& fixture(int n) {
    static Fixture f6(6), f16(16);
    return n == 6 ? f6 : f16;
}

void BM_Occluded(benchmark::State& state) {
    const Fixture& f = fixture(static_cast<int>(state.range(0)));
    VisibilityOptions opt;
    opt.batching = static_cast<VisibilityOptions::Batching>(state.range(1));
    auto v = make_visibility(f.scene, opt);
    std::vector<std::uint8_t> out;
    std::size_t rays = 0;
    for (auto _ : state) rays += bench::cast_occlusion(*v, f.segments, out, 0);
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
    state.counters["triangles"] = static_cast<double>(v->triangle_count());
    std::size_t blocked = 0;
    for (auto b : out) blocked += b;
    state.counters["blocked_fraction"] = double(blocked) / double(out.size());
}

void BM_FirstHit(benchmark::State& state) {
    const Fixture& f = fixture(static_cast<int>(state.range(0)));
    VisibilityOptions opt;
    opt.batching = static_cast<VisibilityOptions::Batching>(state.range(1));
    auto v = make_visibility(f.scene, opt);
    std::vector<RayHit> out;
    std::size_t rays = 0;
    for (auto _ : state) rays += bench::cast_rays(*v, f.rays, out, 0);
    state.SetItemsProcessed(static_cast<std::int64_t>(rays));
    state.counters["triangles"] = static_cast<double>(v->triangle_count());
}

void BM_Build(benchmark::State& state) {
    const Fixture& f = fixture(static_cast<int>(state.range(0)));
    for (auto _ : state) benchmark::DoNotOptimize(make_visibility(f.scene));
    state.counters["patches"] = static_cast<double>(f.scene.patches.size());
}

}  // namespace

// range(0): Cornell subdivision (6 → 1440 triangles, 16 → 10240); range(1): batching mode
// (0 single, 1 packet16, 2 stream).
BENCHMARK(BM_Occluded)
    ->ArgsProduct({{6, 16}, {0, 1, 2}})
    ->ArgNames({"cornell_n", "batching"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_FirstHit)
    ->ArgsProduct({{6, 16}, {0, 2}})
    ->ArgNames({"cornell_n", "batching"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Build)->Arg(6)->Arg(16)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
