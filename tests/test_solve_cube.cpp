// Radiosity and thermal solves on the subdivided unit cube with exact form
// factors (kernels/analytic.h, Schröder & Hanrahan's closed form for every
// pair).

#include <doctest/doctest.h>

#include "formfactor/kernels/analytic.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/scene/scene.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

using namespace formfactor;

namespace {

// The built-in cube split 4×4 per face (96 patches), F from polygon_to_polygon.
FormFactors exact_cube(Scene& scene) {
    scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{4, 0.0});
    const auto n = static_cast<Eigen::Index>(scene.patches.size());
    FormFactors ff;
    ff.F = DenseMatrix::Zero(n, n);
    for (Eigen::Index i = 0; i < n; ++i) {
        ff.areas.push_back(scene.patches[std::size_t(i)].area);
        for (Eigen::Index j = 0; j < n; ++j)
            if (i != j)
                ff.F(i, j) = polygon_to_polygon(scene.patches[std::size_t(i)].polygon,
                                                scene.patches[std::size_t(j)].polygon);
    }
    return ff;
}

}  // namespace

TEST_CASE(
    "solve: subdivided cube with exact F, iterative solvers agree with "
    "the direct one") {
    Scene scene;
    const FormFactors ff = exact_cube(scene);
    // Exact F: closed to ~1e-12, reciprocal.
    const Diagnostics d = diagnose(ff.F, ff.areas);
    CHECK(d.row_sum_min > 1.0 - 1e-10);
    CHECK(d.row_sum_max < 1.0 + 1e-10);
    PatchProperties p = properties_from_scene(scene);
    for (std::size_t i = 0; i < p.size(); ++i) {
        const int face = scene.patches[i].surface;
        p.reflectance[i] = face == 0 ? Rgb(0.8, 0.1, 0.1) : Rgb(0.7, 0.7, 0.7);
        if (face == 5 && i % 16 == 5) p.emission[i] = Rgb(10, 10, 10);  // one small light
    }
    SolverOptions o;
    o.solver = SolverKind::direct;
    const RadiosityResult ref = solve_radiosity(ff, p, o);
    CHECK(ref.balance.relative_defect < 1e-9);
    double bmax = 0.0;
    for (const Rgb& b : ref.radiosity) bmax = std::max(bmax, b.maxCoeff());
    for (SolverKind k : {SolverKind::jacobi, SolverKind::gauss_seidel, SolverKind::shooting}) {
        CAPTURE(to_string(k));
        o.solver = k;
        o.residual = 1e-12;
        const RadiosityResult r = solve_radiosity(ff, p, o);
        CHECK(r.stats.converged);
        double diff = 0.0;
        for (std::size_t i = 0; i < p.size(); ++i)
            diff = std::max(diff, (r.radiosity[i] - ref.radiosity[i]).cwiseAbs().maxCoeff());
        // ‖ΔB‖ ≤ ‖r‖ / (1 − 0.8) with ‖r‖ ≤ 1e-12 ‖B‖.
        CHECK(diff <= 1e-10 * bmax);
    }
    // Thermal on the same matrix: Σ net power = 0 to 1e-9 in the closed
    // enclosure.
    for (std::size_t i = 0; i < p.size(); ++i) {
        p.emissivity[i] = i % 7 == 6 ? 1.0 : 0.2 + 0.13 * double(i % 7);
        p.temperature[i] = 300.0 + 10.0 * double(i % 11);
    }
    const ThermalResult t = solve_thermal(ff, p);
    double abs_sum = 0.0;
    for (double x : t.net_power) abs_sum += std::abs(x);
    CHECK(std::abs(t.total_net_power) < 1e-9 * abs_sum);
}
