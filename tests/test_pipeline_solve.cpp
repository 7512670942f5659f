// The pipeline's solve steps (formfactor/pipeline_solve.h): one default solver per storage, the
// same solution whatever holds F, the closed-model check of the thermal solve, and F per surface
// from a matrix or from the hierarchical operator's products.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "formfactor/pipeline.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/pipeline_sparse.h"
#include "support/scenes.h"

using namespace formfactor;
using formfactor::testing::unit_cube;

namespace {

// Grey walls at 300 K, the patches of the first face at 400 K.
PatchProperties warm_floor(const Scene& scene) {
    PatchProperties p = properties_from_scene(scene);
    for (std::size_t i = 0; i < p.size(); ++i) {
        p.emissivity[i] = 0.8;
        p.temperature[i] = scene.patches[i].surface == 0 ? 400.0 : 300.0;
        p.net_flux[i] = std::nan("");
    }
    return p;
}

double largest_difference(const std::vector<double>& a, const std::vector<double>& b) {
    REQUIRE(a.size() == b.size());
    double d = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
    return d;
}

}  // namespace

TEST_CASE("pipeline solve: the default solver of each storage and problem") {
    CHECK(default_solver(Storage::dense, false) == SolverKind::gauss_seidel);
    CHECK(default_solver(Storage::dense, true) == SolverKind::direct);
    CHECK(default_solver(Storage::sparse, false) == SolverKind::gauss_seidel);
    CHECK(default_solver(Storage::sparse, true) == SolverKind::gmres);
    CHECK(default_solver(Storage::hierarchical, false) == SolverKind::gmres);
    CHECK(default_solver(Storage::hierarchical, true) == SolverKind::gmres);
}

TEST_CASE("pipeline solve: dense and sparse F and the operator give one thermal solution") {
    const Scene scene = unit_cube(3);
    const PatchProperties props = warm_floor(scene);
    SolveOptions o;
    o.thermal = true;
    o.solver.residual = 1e-12;

    o.solver.solver = default_solver(Storage::dense, true);
    const ComputeResult dense = compute_form_factors(scene);
    const SolveResult a = solve(scene, dense.form_factors, props, o);
    REQUIRE(a.thermal);
    CHECK_FALSE(a.radiosity);
    CHECK(a.thermal->closed);  // the cube is a closed model: nothing escapes
    CHECK(a.thermal->escaped_power == 0.0);
    REQUIRE(a.timings.steps.size() == 1);
    CHECK(a.timings.steps[0].first == "solve");

    o.solver.solver = default_solver(Storage::sparse, true);
    const SparseComputeResult sparse = compute_sparse_form_factors(scene, {}, {});
    const SolveResult b = solve(scene, sparse.form_factors, props, o);
    REQUIRE(b.thermal);
    CHECK(largest_difference(a.thermal->net_flux, b.thermal->net_flux) < 1e-6);

    o.solver.solver = default_solver(Storage::hierarchical, true);
    StepTimes times;
    const HierarchicalFormFactors H = compute_hierarchical_operator(scene, {}, &times);
    REQUIRE(times.steps.size() == 1);
    CHECK(times.steps[0].first == "hierarchical operator");
    const SolveResult c = solve(scene, H, props, o);
    REQUIRE(c.thermal);
    CHECK(largest_difference(a.thermal->temperature, c.thermal->temperature) < 1e-6);
}

TEST_CASE("pipeline solve: radiosity is the solver's own answer") {
    const Scene scene = unit_cube(2);
    PatchProperties props = properties_from_scene(scene);
    for (std::size_t i = 0; i < props.size(); ++i) {
        props.reflectance[i] = Rgb(0.5, 0.6, 0.7);
        props.emission[i] = scene.patches[i].surface == 5 ? Rgb(1, 1, 1) : Rgb(0, 0, 0);
    }
    const FormFactors F = compute_form_factors(scene).form_factors;
    SolveOptions o;
    o.solver.solver = SolverKind::direct;
    const SolveResult r = solve(scene, F, props, o);
    REQUIRE(r.radiosity);
    CHECK_FALSE(r.thermal);
    const RadiosityResult direct = solve_radiosity(F, props, o.solver);
    REQUIRE(r.radiosity->radiosity.size() == direct.radiosity.size());
    for (std::size_t i = 0; i < direct.radiosity.size(); ++i)
        CHECK(r.radiosity->radiosity[i] == direct.radiosity[i]);
}

TEST_CASE("pipeline solve: F per surface from a matrix and from the operator") {
    SUBCASE("one patch per surface: the patch matrix itself") {
        const Scene scene = unit_cube(1);
        const FormFactors F = compute_form_factors(scene).form_factors;
        const SurfaceFormFactors<FormFactors> s = per_surface(scene, F);
        CHECK(s.groups.size() == 6);
        CHECK_FALSE(s.aggregated);
        CHECK(&s.of(F) == &F);
    }
    SUBCASE("several patches per surface: aggregated, closed rows") {
        const Scene scene = unit_cube(3);
        const FormFactors F = compute_form_factors(scene).form_factors;
        const SurfaceFormFactors<FormFactors> s = per_surface(scene, F);
        REQUIRE(s.aggregated);
        const FormFactors& G = s.of(F);
        REQUIRE(G.size() == 6);
        // Each face sees its opposite with 0.19982 (parallel unit squares one apart, Howell's
        // catalog) and the four others with 0.20004 each.
        for (Eigen::Index i = 0; i < 6; ++i) {
            CHECK(G.F.row(i).sum() == doctest::Approx(1.0));
            double least = 1.0;
            for (Eigen::Index j = 0; j < 6; ++j)
                if (j != i) least = std::min(least, G.F(i, j));
            CHECK(least == doctest::Approx(0.199825).epsilon(1e-4));
        }

        const SurfaceFormFactors<SparseFormFactors> sparse =
            per_surface(scene, compute_sparse_form_factors(scene, {}, {}).form_factors);
        REQUIRE(sparse.aggregated);
        CHECK(sparse.aggregated->n == 6);

        const SurfaceFormFactors<FormFactors> op =
            per_surface(scene, compute_hierarchical_operator(scene, {}));
        REQUIRE(op.aggregated);
        CHECK((op.aggregated->F - G.F).cwiseAbs().maxCoeff() < 1e-6);
        for (std::size_t g = 0; g < 6; ++g)
            CHECK(op.aggregated->areas[g] == doctest::Approx(G.areas[g]));
    }
}
