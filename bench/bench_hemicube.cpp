// Projection methods: hemicubes (and hemiplanes) per second on a ~10k-triangle scene, and the
// time and error of both methods on scenes with known answers, at several resolutions.
//
//   build/bench/bench_hemicube --benchmark_filter=Speed     (throughput, threads 1 and 2)
//   build/bench/bench_hemicube --benchmark_filter=Accuracy  (error counters vs Howell's values)

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "../tests/support/method_runner.h"
#include "formfactor/methods/hemicube.h"
#include "formfactor/methods/hemiplane.h"
#include "formfactor/scene/scene.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

// Quad q split n × n, each cell into two triangles (or kept as a quad).
std::vector<Polygon> tessellate(const Polygon& q, int n, bool triangles) {
    auto at = [&](double s, double t) {
        return (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3];
    };
    std::vector<Polygon> out;
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const double s0 = double(i) / n, s1 = double(i + 1) / n;
            const double t0 = double(j) / n, t1 = double(j + 1) / n;
            const Vec3 a = at(s0, t0), b = at(s1, t0), c = at(s1, t1), d = at(s0, t1);
            if (triangles) {
                out.push_back(Polygon{{a, b, c}});
                out.push_back(Polygon{{a, c, d}});
            } else {
                out.push_back(Polygon{{a, b, c, d}});
            }
        }
    }
    return out;
}

void add_surface(Scene& s, const Polygon& q, int n, bool obstruction, bool triangles) {
    Surface surf;
    surf.polygon = q;
    surf.obstruction = obstruction;
    s.surfaces.push_back(surf);
    const int index = static_cast<int>(s.surfaces.size()) - 1;
    for (const Polygon& p : tessellate(q, n, triangles)) {
        if (obstruction) {
            Surface o;
            o.polygon = p;
            o.obstruction = true;
            s.surfaces.push_back(o);
        } else {
            s.patches.push_back(make_patch(p, index));
        }
    }
    if (obstruction) s.surfaces.erase(s.surfaces.begin() + index);
}

// Faces of the box [lo, hi], outward (inward = false) or inward; without its bottom when
// `open_bottom`.
std::vector<Polygon> box(const Vec3& lo, const Vec3& hi, bool inward, bool open_bottom) {
    const double x0 = lo.x(), y0 = lo.y(), z0 = lo.z(), x1 = hi.x(), y1 = hi.y(), z1 = hi.z();
    std::vector<Polygon> f = {
        Polygon{{Vec3(x0, y0, z0), Vec3(x1, y0, z0), Vec3(x1, y1, z0), Vec3(x0, y1, z0)}},
        Polygon{{Vec3(x0, y0, z1), Vec3(x0, y1, z1), Vec3(x1, y1, z1), Vec3(x1, y0, z1)}},
        Polygon{{Vec3(x0, y0, z0), Vec3(x0, y1, z0), Vec3(x0, y1, z1), Vec3(x0, y0, z1)}},
        Polygon{{Vec3(x1, y0, z0), Vec3(x1, y0, z1), Vec3(x1, y1, z1), Vec3(x1, y1, z0)}},
        Polygon{{Vec3(x0, y0, z0), Vec3(x0, y0, z1), Vec3(x1, y0, z1), Vec3(x1, y0, z0)}},
        Polygon{{Vec3(x0, y1, z0), Vec3(x1, y1, z0), Vec3(x1, y1, z1), Vec3(x0, y1, z1)}},
    };
    if (!inward) {
        for (Polygon& p : f) std::reverse(p.vertices.begin(), p.vertices.end());
    }
    if (open_bottom) f.erase(f.begin());
    return f;
}

// A Cornell-like box: the room's six faces, 12 × 12 cells of two triangles each, are the
// patches (1728 rows); two blocks standing on the floor are obstructions, 20 × 20 × 2 triangles
// per face (8000). 9728 triangles in all.
Scene cornell_10k() {
    Scene s;
    s.name = "cornell-10k";
    s.materials.push_back({});
    for (const Polygon& q : box(Vec3(0, 0, 0), Vec3(1, 1, 1), true, false)) {
        add_surface(s, q, 12, false, true);
    }
    for (const Polygon& q : box(Vec3(0.15, 0.1, 0), Vec3(0.45, 0.4, 0.3), false, true)) {
        add_surface(s, q, 20, true, true);
    }
    for (const Polygon& q : box(Vec3(0.55, 0.5, 0), Vec3(0.85, 0.8, 0.6), false, true)) {
        add_surface(s, q, 20, true, true);
    }
    return s;
}

const Scene& scene_10k() {
    static const Scene s = cornell_10k();
    return s;
}

Scene plates_scene() {
    Scene s;
    s.materials.push_back({});
    add_surface(s, Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}}, 1, false,
                false);
    add_surface(s, Polygon{{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)}}, 1, false,
                false);
    return s;
}

Scene cube_scene(int n) {
    Scene s;
    s.materials.push_back({});
    for (const Polygon& q : box(Vec3(0, 0, 0), Vec3(1, 1, 1), true, false)) {
        add_surface(s, q, n, false, false);
    }
    return s;
}

// CPU seconds used by the whole process, all threads (robust to a shared, loaded machine).
double process_cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::unique_ptr<Method> method_for(int which) {
    if (which == 0) return std::make_unique<HemicubeMethod>();
    return std::make_unique<HemiplaneMethod>();
}

// Args: method (0 hemicube, 1 hemiplane), resolution, threads.
void Speed(benchmark::State& state) {
    const Scene& s = scene_10k();
    const auto method = method_for(static_cast<int>(state.range(0)));
    MethodOptions o;
    o.resolution = static_cast<int>(state.range(1));
    o.threads = static_cast<int>(state.range(2));
    std::size_t projections = 0;
    const double cpu0 = process_cpu_seconds();
    for (auto _ : state) {
        nlohmann::json details;
        FormFactors F = run_method(*method, s, o, details);
        benchmark::DoNotOptimize(F.F.data());
        projections += s.patches.size();
    }
    state.counters["projections_per_s"] =
        benchmark::Counter(static_cast<double>(projections), benchmark::Counter::kIsRate);
    // Per core: projections per CPU second over all threads. On an idle machine the
    // wall-clock rate with T threads approaches T times this.
    state.counters["per_core_per_cpu_s"] =
        static_cast<double>(projections) / (process_cpu_seconds() - cpu0);
    state.counters["triangles"] = 9728;
    state.SetLabel(method->name());
}
BENCHMARK(Speed)
    ->ArgNames({"method", "R", "threads"})
    ->Args({0, 256, 1})
    ->Args({0, 256, 2})
    ->Args({1, 256, 1})
    ->Args({1, 256, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

constexpr double kC11 = 0.19982489569838746;  // plates, and the cube's opposite faces
constexpr double kC14 = 0.20004377607540316;  // the cube's adjacent faces

// Args: method, resolution, case (0: plates, 16 points; 1: cube 4×4 per face, 4 points each).
void Accuracy(benchmark::State& state) {
    const int which = static_cast<int>(state.range(0));
    const int R = static_cast<int>(state.range(1));
    const bool cube = state.range(2) == 1;
    const Scene s = cube ? cube_scene(4) : plates_scene();
    const auto method = method_for(which);
    MethodOptions o;
    o.resolution = R;
    o.points = cube ? 4 : 16;
    o.threads = 2;
    nlohmann::json details;
    DenseMatrix M;
    for (auto _ : state) {
        FormFactors F = run_method(*method, s, o, details);
        benchmark::DoNotOptimize(F.F.data());
        M = std::move(F.F);
    }
    const struct { const DenseMatrix& F; } F{M};
    if (cube) {
        // Face-to-face factors: area-weighted sums of the 16 × 16 blocks.
        auto block = [&](int a, int b) {
            double sum = 0.0;
            for (int i = 0; i < 16; ++i) {
                for (int j = 0; j < 16; ++j) sum += F.F(16 * a + i, 16 * b + j);
            }
            return sum / 16.0;
        };
        state.counters["err_opposite"] = block(0, 1) - kC11;
        state.counters["err_adjacent"] = block(0, 2) - kC14;
        double worst = 0.0;
        for (Eigen::Index i = 0; i < F.F.rows(); ++i) {
            worst = std::max(worst, std::abs(F.F.row(i).sum() - 1.0));
        }
        state.counters["row_sum_dev"] = worst;
    } else {
        state.counters["err_plates"] = F.F(0, 1) - kC11;
    }
    if (which == 1) {
        state.counters["neglected"] = details["neglected_fraction"].get<double>();
        state.counters["ambiguous"] = details["ambiguous_max"].get<double>();
    }
    state.SetLabel(std::string(method->name()) + (cube ? " cube4x4/4pts" : " plates/16pts"));
}
BENCHMARK(Accuracy)
    ->ArgNames({"method", "R", "case"})
    ->ArgsProduct({{0, 1}, {64, 128, 256, 512, 1024}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
