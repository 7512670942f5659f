// Benchmark of the hierarchical operator (formfactor/matrix/hierarchical.h) on the closed unit
// cube room, every face split n × n (room_scene(n, RoomBox::kNone): 6n² patches), thermal
// solve by GMRES through its products, F never formed.
//
//  - BM_HierarchicalVsDense/n: the same thermal problem solved on the exact dense matrix
//    (analytic, GMRES to 1e-12) and on the operator at error target 1e-6 and 1e-4: the largest
//    relative difference of the patch radiosities, and of the net power of each wall relative
//    to the total emitted power Σ A ε σ T⁴. n = 41 (10,086 patches) by default.
//  - BM_HierarchicalClosedRoom/n: build + solve time, process CPU time, peak RSS (of the whole
//    process: cumulative, cases run smallest first), the operator's size and ranks. n = 41 and
//    129 (99,846 patches) by default; FF_BENCH_HIER_N=a,b,... adds others (n = 408 is 998,784
//    patches: about 15 GB).
//
// The problem: wall k (of the six, by normal) has ε_k = 0.1 + 0.15 k, the floor is at 1000 K,
// the ceiling at 300 K, two walls adiabatic, two at 500 K.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <ctime>
#include <string>

#include "bench_common.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/hierarchical_build.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/room.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/thermal.h"

using namespace formfactor;

using bench::process_cpu_seconds;

namespace {

// Wall index 0..5 of a patch of the room, from its inward normal.
int wall_of(const Patch& p) {
    for (int a = 0; a < 3; ++a) {
        if (p.normal[a] > 0.5) return 2 * a;
        if (p.normal[a] < -0.5) return 2 * a + 1;
    }
    return 0;
}

PatchProperties problem(const Scene& s) {
    PatchProperties props = properties_from_scene(s);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (std::size_t i = 0; i < s.patches.size(); ++i) {
        const int w = wall_of(s.patches[i]);
        props.emissivity[i] = 0.1 + 0.15 * w;
        props.net_flux[i] = nan;
        props.temperature[i] = nan;
        switch (w) {
            case 4:
                props.temperature[i] = 1000.0;
                break;  // floor (+z normal)
            case 5:
                props.temperature[i] = 300.0;
                break;  // ceiling
            case 0:
            case 1:
                props.net_flux[i] = 0.0;
                break;
            default:
                props.temperature[i] = 500.0;
                break;
        }
    }
    return props;
}

void BM_HierarchicalVsDense(benchmark::State& state) {
    const Scene s = room_scene(static_cast<int>(state.range(0)), RoomBox::kNone);
    const PatchProperties props = problem(s);
    ThermalOptions to;
    to.solver.solver = SolverKind::gmres;
    to.solver.residual = 1e-12;
    for (auto _ : state) {
        ComputeOptions co;
        co.method = MethodKind::analytic;
        const double t0 = process_cpu_seconds();
        const FormFactors ff = compute_form_factors(s, co).form_factors;
        const ThermalResult ref = solve_thermal(ff, props, to);
        state.counters["dense_cpu_s"] = process_cpu_seconds() - t0;
        double emitted = 0.0;
        for (std::size_t i = 0; i < s.patches.size(); ++i)
            if (!std::isnan(props.temperature[i]))
                emitted += ff.areas[i] * props.emissivity[i] * kStefanBoltzmann *
                           std::pow(props.temperature[i], 4);
        for (const double target : {1e-6, 1e-4}) {
            HierarchicalOptions ho;
            ho.tolerance = target;
            const double t1 = process_cpu_seconds();
            const HierarchicalFormFactors H = build_hierarchical(s, ho);
            ThermalOptions hto = to;
            hto.solver.residual = 1e-10;
            const ThermalResult h = solve_thermal(H, props, hto);
            const std::string tag = target == 1e-6 ? "_1e-6" : "_1e-4";
            state.counters["hier_cpu_s" + tag] = process_cpu_seconds() - t1;
            double dj = 0.0;
            double wall_ref[6] = {}, wall_h[6] = {};
            for (std::size_t i = 0; i < s.patches.size(); ++i) {
                dj = std::max(dj, std::abs(h.radiosity[i] - ref.radiosity[i]) / ref.radiosity[i]);
                wall_ref[wall_of(s.patches[i])] += ref.net_power[i];
                wall_h[wall_of(s.patches[i])] += h.net_power[i];
            }
            double dq = 0.0;
            for (int w = 0; w < 6; ++w)
                dq = std::max(dq, std::abs(wall_h[w] - wall_ref[w]) / emitted);
            state.counters["radiosity_rel" + tag] = dj;
            state.counters["wall_power_rel" + tag] = dq;
        }
    }
    state.counters["patches"] = static_cast<double>(s.patches.size());
    state.counters["peak_rss_MB"] = peak_memory_bytes() / 1e6;
}

void BM_HierarchicalClosedRoom(benchmark::State& state) {
    const Scene s = room_scene(static_cast<int>(state.range(0)), RoomBox::kNone);
    const PatchProperties props = problem(s);
    const double cpu0 = process_cpu_seconds();
    for (auto _ : state) {
        HierarchicalOptions ho;
        ho.tolerance = 1e-6;
        const HierarchicalFormFactors H = build_hierarchical(s, ho);
        ThermalOptions to;
        to.solver.solver = SolverKind::gmres;
        to.solver.residual = 1e-8;
        const ThermalResult r = solve_thermal(H, props, to);
        const HierarchicalStats& st = H.stats();
        state.counters["build_s"] = st.seconds;
        state.counters["solve_s"] = r.stats.seconds;
        state.counters["products"] = static_cast<double>(r.stats.iterations);
        state.counters["operator_MB"] = st.bytes / 1e6;
        state.counters["mean_rank"] = st.mean_rank;
        state.counters["low_rank_blocks"] = static_cast<double>(st.low_rank_blocks);
        state.counters["dense_blocks"] = static_cast<double>(st.dense_blocks);
        state.counters["entries_M"] = static_cast<double>(st.entries_computed) / 1e6;
        state.counters["balance_defect"] = r.relative_balance_defect;
    }
    state.counters["patches"] = static_cast<double>(s.patches.size());
    state.counters["cpu_s"] = process_cpu_seconds() - cpu0;
    state.counters["peak_rss_MB"] = peak_memory_bytes() / 1e6;
}

}  // namespace

BENCHMARK(BM_HierarchicalVsDense)->Arg(41)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_HierarchicalClosedRoom)
    ->Arg(41)
    ->Arg(129)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

// Other sizes on request (FF_BENCH_HIER_N, comma-separated n).
static const bool kLarger = bench::register_sizes_from_env(
    "BM_HierarchicalClosedRoom", BM_HierarchicalClosedRoom, "FF_BENCH_HIER_N");

BENCHMARK_MAIN();
