// Radiosity solvers and matrix repair on random reciprocal matrices (N patches, row sums
// ≤ 0.95, ρ = 0.7 / 0.5 / 0.3 per channel, one emitter), tolerance 1e-8.

#include <benchmark/benchmark.h>

#include <cmath>

#include "formfactor/matrix/repair.h"
#include "formfactor/solve/radiosity.h"

// random_open_matrix, shared with the tests.
#include "../tests/support/fixtures.h"

using namespace formfactor;

namespace {

PatchProperties props(int n) {
    PatchProperties p;
    p.reflectance.assign(std::size_t(n), Rgb(0.7, 0.5, 0.3));
    p.emission.assign(std::size_t(n), Rgb::Zero());
    p.emission[0] = Rgb(10, 10, 10);
    p.emissivity.assign(std::size_t(n), 0.9);
    p.temperature.assign(std::size_t(n), std::nan(""));
    p.net_flux.assign(std::size_t(n), std::nan(""));
    return p;
}

void solve(benchmark::State& state, SolverKind kind) {
    const int n = static_cast<int>(state.range(0));
    const FormFactors ff = formfactor::testing::random_open_matrix(n, 1);
    const PatchProperties p = props(n);
    SolverOptions o;
    o.solver = kind;
    long long it = 0;
    for (auto _ : state) {
        const RadiosityResult r = solve_radiosity(ff, p, o);
        it = r.stats.iterations;
        benchmark::DoNotOptimize(r.radiosity.data());
    }
    state.counters["iterations"] = static_cast<double>(it);
}

void BM_jacobi(benchmark::State& s) { solve(s, SolverKind::jacobi); }
void BM_gauss_seidel(benchmark::State& s) { solve(s, SolverKind::gauss_seidel); }
void BM_shooting(benchmark::State& s) { solve(s, SolverKind::shooting); }
void BM_direct(benchmark::State& s) { solve(s, SolverKind::direct); }

void BM_repair_both(benchmark::State& state) {
    const int n = static_cast<int>(state.range(0));
    const FormFactors ff = formfactor::testing::random_open_matrix(n, 1);
    RepairOptions o;
    o.mode = RepairMode::both;
    o.force_closure = true;
    int it = 0;
    for (auto _ : state) {
        DenseMatrix F = ff.F;
        it = repair(F, ff.areas, o).closure_iterations;
        benchmark::DoNotOptimize(F.data());
    }
    state.counters["iterations"] = it;
}

}  // namespace

BENCHMARK(BM_jacobi)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_gauss_seidel)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_shooting)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_direct)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_repair_both)->Arg(500)->Arg(2000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
