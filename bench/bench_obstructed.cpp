// Benchmark of the obstruction-aware analytic method on the room scene (formfactor/scene/room.h):
// a unit cube room, faces inward, each split n×n, with a floating box [0.3,0.7]²×[0.1,0.5] whose
// faces are split (n/2)×(n/2): n = 16 (1,920 patches) and n = 32 (7,680 patches), the full matrix
// at --tolerance 1e-6 (partly hidden pairs; the others are exact or exactly 0), and n = 32 with
// the box as six obstruction-only faces (the VS3 `O` version) read back from a VS3 file.
// Reported: wall time, process CPU time (the machine is shared), peak RSS, the pair classes,
// refinement, the error estimate, and the row sums of the closed room. BM_RoomAccuracy compares
// n = 8 at tolerance 1e-6 with the same at 1e-9 (max |ΔF| over all entries). BM_Curved: the
// room with a faceted sphere and cylinder (curved geometry, every facet a surface).
//
// The same scenes against View3D 3.2, side by side in one run: bench/view3d_compare.py
// (figures in docs/benchmarks.md).

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>

#include "../tests/support/method_runner.h"
#include "../tests/support/temp_dir.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene_io.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

double process_cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double peak_rss_mb() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_maxrss) / 1024.0;
}

void BM_Room(benchmark::State& state) {
    const int n = static_cast<int>(state.range(0));
    const bool vs3_obstruction = state.range(1) != 0;
    Scene scene = room_scene(n, vs3_obstruction ? RoomBox::kObstruction : RoomBox::kPatches);
    if (vs3_obstruction) {
        // A folder of its own: two benchmark runs at once must not read each other's file.
        const testing::TempDir dir;
        const std::string path = dir.file("room.vs3");
        save_vs3(scene, path);
        scene = load_scene(path);
    }
    const auto method = make_method("analytic");
    MethodOptions opt;
    opt.tolerance = 1e-6;  // what --tolerance 1e-6 sets; visible pairs stay at ≤ 1e-10
    opt.obstructed_tolerance = 1e-6;
    nlohmann::json details;
    std::unique_ptr<FormFactors> result;
    double cpu = 0;
    for (auto _ : state) {
        details = nlohmann::json::object();
        const double c0 = process_cpu_seconds();
        result = std::make_unique<FormFactors>(run_method(*method, scene, opt, details));
        cpu += process_cpu_seconds() - c0;
    }
    const Diagnostics d = diagnose(result->F, result->areas);
    const auto& ob = details["obstructions"];
    state.counters["patches"] = static_cast<double>(scene.patches.size());
    state.counters["cpu_s"] = cpu / static_cast<double>(state.iterations());
    state.counters["peak_rss_MB"] = peak_rss_mb();
    state.counters["visible"] = ob["patch_pairs_visible"].get<double>();
    state.counters["hidden"] = ob["patch_pairs_hidden"].get<double>();
    state.counters["partly_hidden"] = ob["patch_pairs_partly_hidden"].get<double>();
    state.counters["point_evals"] = ob["point_evaluations"].get<double>();
    state.counters["max_err_est"] = ob["max_error_estimate"].get<double>();
    state.counters["s_classify"] = ob["seconds_classification"].get<double>();
    state.counters["s_partly_hidden"] = ob["seconds_partly_hidden"].get<double>();
    state.counters["row_sum_min-1"] = d.row_sum_min - 1.0;
    state.counters["row_sum_max-1"] = d.row_sum_max - 1.0;
    state.counters["recip_defect"] = d.max_reciprocity_defect;
}
BENCHMARK(BM_Room)
    ->Args({16, 0})
    ->Args({32, 0})
    ->Args({32, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

// Curved geometry: the room n × n without its box, with a faceted UV sphere (centre
// (0.35, 0.5, 0.45), radius 0.2, `seg` segments, seg/2 rings, triangles) and a closed faceted
// cylinder (centre (0.72, 0.5), radius 0.12, z 0.15…0.75, `seg` sides, fan caps), every facet a
// radiating surface: args {n, seg}; {4, 16} is 368 patches, {8, 40} is 2,024.
Scene curved_room(int n, int seg) {
    Scene scene = room_scene(n, RoomBox::kNone);
    scene.patches.clear();
    auto add = [&](std::vector<Vec3> v) {
        Surface sf;
        sf.name = "c" + std::to_string(scene.surfaces.size());
        sf.polygon.vertices = std::move(v);
        scene.surfaces.push_back(std::move(sf));
    };
    const int rings = seg / 2;
    auto sp = [&](int i, int j) {
        const double th = kPi * i / rings, ph = 2 * kPi * j / seg;
        return Vec3(0.35 + 0.2 * std::sin(th) * std::cos(ph),
                    0.5 + 0.2 * std::sin(th) * std::sin(ph), 0.45 + 0.2 * std::cos(th));
    };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < seg; ++j) {
            if (i > 0) add({sp(i, j), sp(i + 1, j), sp(i, j + 1)});
            if (i < rings - 1) add({sp(i + 1, j), sp(i + 1, j + 1), sp(i, j + 1)});
        }
    auto cp = [&](int j, double z) {
        const double ph = 2 * kPi * j / seg;
        return Vec3(0.72 + 0.12 * std::cos(ph), 0.5 + 0.12 * std::sin(ph), z);
    };
    for (int j = 0; j < seg; ++j) {
        add({cp(j, 0.15), cp(j + 1, 0.15), cp(j + 1, 0.75), cp(j, 0.75)});
        add({Vec3(0.72, 0.5, 0.75), cp(j, 0.75), cp(j + 1, 0.75)});
        add({Vec3(0.72, 0.5, 0.15), cp(j + 1, 0.15), cp(j, 0.15)});
    }
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

void BM_Curved(benchmark::State& state) {
    const Scene scene =
        curved_room(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const auto method = make_method("analytic");
    MethodOptions opt;  // defaults: 1e-10 visible, 1e-6 partly hidden
    nlohmann::json details;
    double cpu = 0;
    for (auto _ : state) {
        details = nlohmann::json::object();
        const double c0 = process_cpu_seconds();
        benchmark::DoNotOptimize(run_method(*method, scene, opt, details));
        cpu += process_cpu_seconds() - c0;
    }
    const auto& ob = details["obstructions"];
    state.counters["patches"] = static_cast<double>(scene.patches.size());
    state.counters["cpu_s"] = cpu / static_cast<double>(state.iterations());
    state.counters["peak_rss_MB"] = peak_rss_mb();
    state.counters["partly_hidden"] = ob["patch_pairs_partly_hidden"].get<double>();
    state.counters["cells"] = ob["cells"].get<double>();
    state.counters["point_evals"] = ob["point_evaluations"].get<double>();
    state.counters["max_err_est"] = ob["max_error_estimate"].get<double>();
}
BENCHMARK(BM_Curved)
    ->Args({4, 16})
    ->Args({8, 40})
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->UseRealTime();

void BM_RoomAccuracy(benchmark::State& state) {
    const Scene scene = room_scene(8, RoomBox::kPatches);
    const auto method = make_method("analytic");
    MethodOptions coarse, fine;
    coarse.tolerance = coarse.obstructed_tolerance = 1e-6;
    fine.tolerance = 1e-12;
    fine.obstructed_tolerance = 1e-9;
    nlohmann::json d1, d2;
    double diff = 0;
    for (auto _ : state) {
        const FormFactors a = run_method(*method, scene, coarse, d1);
        const FormFactors b = run_method(*method, scene, fine, d2);
        diff = (a.F - b.F).cwiseAbs().maxCoeff();
    }
    state.counters["max_abs_diff_1e-6_vs_1e-9"] = diff;
    state.counters["est_1e-6"] = d1["obstructions"]["max_error_estimate"].get<double>();
}
BENCHMARK(BM_RoomAccuracy)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
