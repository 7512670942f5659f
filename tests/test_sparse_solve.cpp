// The radiosity and thermal solvers on a sparse (CSR) F: the same solutions as on the dense F,
// products bit-identical for any thread count, the dropped mass of a threshold said and
// accounted for, and the solvers that need the dense F refused.

#include <doctest/doctest.h>

#include <cmath>

#include "formfactor/core/error.h"
#include "formfactor/matrix/sparse_repair.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/city.h"
#include "formfactor/scene/scene_io.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"
#include "solve/linear_system.h"
#include "support/fixtures.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

PatchProperties grey_props(std::size_t n, double rho, double eps) {
    PatchProperties p;
    p.reflectance.assign(n, Rgb(rho, rho, rho));
    p.emission.assign(n, Rgb::Zero());
    p.emissivity.assign(n, eps);
    p.temperature.assign(n, std::nan(""));
    p.net_flux.assign(n, std::nan(""));
    return p;
}

// F of the closed unit cube, 6×6 patches a face (216 patches), exact.
const FormFactors& cube6() {
    static const FormFactors ff = [] {
        Scene s = load_scene("cube");
        subdivide(s, SubdivisionOptions{6, 0.0});
        return compute_form_factors(s, {}).form_factors;
    }();
    return ff;
}

double max_rel_diff(const std::vector<double>& a, const std::vector<double>& b) {
    double m = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        m = std::max(m, std::abs(a[i] - b[i]));
        scale = std::max(scale, std::abs(b[i]));
    }
    return m / scale;
}

}  // namespace

TEST_CASE("sparse solve: radiosity on CSR agrees with the dense direct solve, every solver") {
    const FormFactors& ff = cube6();
    const SparseFormFactors sf = to_sparse(ff);
    const std::size_t n = ff.size();
    PatchProperties p = grey_props(n, 0.6, 0.9);
    for (std::size_t i = 0; i < n; ++i)
        p.reflectance[i] = Rgb(0.2 + 0.7 * double(i % 5) / 4, 0.5, 0.8);
    for (std::size_t i = 0; i < 36; ++i) p.emission[i] = Rgb(5.0, 3.0, 1.0);  // the x = 0 face
    SolverOptions o;
    o.solver = SolverKind::direct;
    o.residual = 1e-13;
    const RadiosityResult ref = solve_radiosity(ff, p, o);
    for (SolverKind k : {SolverKind::gauss_seidel, SolverKind::gmres, SolverKind::jacobi}) {
        CAPTURE(to_string(k));
        o.solver = k;
        o.residual = 1e-11;
        const RadiosityResult r = solve_radiosity(sf, p, o);
        CHECK(r.stats.converged);
        CHECK(r.stats.residual <= 1e-11);
        // ‖B − B*‖∞ ≤ ‖r‖∞ ‖B‖∞ / (1 − ρ_max) = 10 × 1e-11 relative (ρ ≤ 0.9).
        double err = 0.0, scale = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            err = std::max(err, (r.radiosity[i] - ref.radiosity[i]).cwiseAbs().maxCoeff());
            scale = std::max(scale, ref.radiosity[i].cwiseAbs().maxCoeff());
        }
        CHECK(err <= 1.1e-10 * scale);
        for (int c = 0; c < 3; ++c) {
            CHECK(r.balance.emitted[c] == doctest::Approx(ref.balance.emitted[c]).epsilon(1e-14));
            CHECK(r.balance.absorbed[c] == doctest::Approx(ref.balance.absorbed[c]).epsilon(1e-9));
        }
        CHECK(r.balance.relative_defect < 1e-8);
        CHECK(r.stats.warnings.empty());
    }
}

TEST_CASE("sparse solve: thermal on CSR agrees with the dense solve, products thread-independent") {
    const FormFactors& ff = cube6();
    const SparseFormFactors sf = to_sparse(ff);
    const std::size_t n = ff.size();
    PatchProperties p = grey_props(n, 0.5, 0.8);
    for (std::size_t i = 0; i < n; ++i) {
        p.emissivity[i] = 0.1 + 0.8 * double(i % 7) / 6;  // down to 0.1: a stiff system
        if (i < 36)
            p.temperature[i] = 600.0;  // hot face
        else if (i < 72)
            p.temperature[i] = 300.0;  // cold face
        else if (i % 2)
            p.net_flux[i] = 50.0;  // heated patches, the rest adiabatic
    }
    ThermalOptions to;
    to.solver.solver = SolverKind::direct;
    to.solver.residual = 1e-13;
    const ThermalResult ref = solve_thermal(ff, p, to);
    for (SolverKind k : {SolverKind::gmres, SolverKind::gauss_seidel, SolverKind::jacobi}) {
        CAPTURE(to_string(k));
        to.solver.solver = k;
        to.solver.residual = 1e-12;
        const ThermalResult r = solve_thermal(sf, p, to);
        CHECK(r.stats.converged);
        CHECK(max_rel_diff(r.radiosity, ref.radiosity) < 1e-9);
        CHECK(max_rel_diff(r.temperature, ref.temperature) < 1e-9);
        CHECK(std::abs(r.total_net_power - ref.total_net_power) <
              1e-8 * std::abs(ref.net_power[0]) * 36);
        CHECK(r.relative_balance_defect < 1e-8);
    }
    // y = F x on CSR: bit-identical for 1 and 2 threads, equal to the dense product to rounding.
    detail::Columns x(static_cast<Eigen::Index>(n), 2), y1, y2, yd;
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
        x(i, 0) = std::sin(double(i));
        x(i, 1) = 1.0 + double(i % 3);
    }
    detail::multiply(sf, x, y1, 1);
    detail::multiply(sf, x, y2, 2);
    detail::multiply(ff.F, x, yd, 1);
    CHECK((y1.array() == y2.array()).all());
    CHECK((y1 - yd).cwiseAbs().maxCoeff() < 1e-14);
}

TEST_CASE("sparse solve: direct and shooting are refused, sizes are checked") {
    const SparseFormFactors sf = to_sparse(cube_matrix());
    const PatchProperties p = grey_props(6, 0.5, 0.9);
    for (SolverKind k : {SolverKind::direct, SolverKind::shooting}) {
        SolverOptions o;
        o.solver = k;
        CHECK_THROWS_AS(solve_radiosity(sf, p, o), OptionError);
        ThermalOptions to;
        to.solver.solver = k;
        CHECK_THROWS_AS(solve_thermal(sf, p, to), OptionError);
    }
    SolverOptions o;
    o.solver = SolverKind::gmres;
    CHECK_THROWS_AS(solve_radiosity(sf, grey_props(5, 0.5, 0.9), o), Error);
}

TEST_CASE("sparse solve: a threshold's dropped mass is said, and closure puts it back") {
    const FormFactors& ff = cube6();
    const std::size_t n = ff.size();
    PatchProperties p = grey_props(n, 0.5, 0.7);
    for (std::size_t i = 0; i < 36; ++i) p.temperature[i] = 500.0;
    for (std::size_t i = 36; i < 72; ++i) p.temperature[i] = 300.0;  // the rest adiabatic
    ThermalOptions to;
    to.solver.solver = SolverKind::direct;
    to.solver.residual = 1e-13;
    const ThermalResult ref = solve_thermal(ff, p, to);
    to.solver.solver = SolverKind::gmres;
    to.solver.residual = 1e-12;

    // Entries ≤ 1e-3 dropped: up to a few per cent of a row is missing, the solve sees it as a
    // black environment at 0 K and says so.
    SparseFormFactors thr = to_sparse(ff, 1e-3);
    double dropped = 0.0;
    for (double v : thr.dropped) dropped = std::max(dropped, v);
    REQUIRE(dropped > 1e-3);
    const ThermalResult open = solve_thermal(thr, p, to);
    bool said = false;
    for (const auto& w : open.warnings) said = said || w.find("dropped mass") != std::string::npos;
    CHECK(said);
    bool advised = false;  // the option that puts it back, by its library name
    for (const auto& w : open.warnings)
        advised = advised || w.find("`repair` closure or both puts it back") != std::string::npos;
    CHECK(advised);
    CHECK(open.escaped_power > 0.0);  // energy lost to the "environment" the threshold made

    // The conservative closure puts the mass back on the stored entries: reciprocal, rows 1,
    // no warning, and the temperatures come back close to the exact ones.
    SparseRepairOptions ro;
    ro.closure = true;
    repair(thr, ro);
    const ThermalResult closed = solve_thermal(thr, p, to);
    for (const auto& w : closed.warnings) CHECK(w.find("dropped mass") == std::string::npos);
    CHECK(std::abs(closed.escaped_power) < 1e-9 * std::abs(ref.net_power[0]) * 36);
    CHECK(max_rel_diff(closed.temperature, ref.temperature) < 0.05);
    CHECK(max_rel_diff(closed.temperature, ref.temperature) <
          max_rel_diff(open.temperature, ref.temperature));

    // Every patch adiabatic or with a flux in the closed cube: singular, also when a threshold
    // left the rows a little short of 1 (they are within twice the dropped mass of 1).
    PatchProperties flux = grey_props(n, 0.5, 0.7);
    for (std::size_t i = 0; i < 36; ++i) flux.net_flux[i] = 10.0;
    CHECK_THROWS_AS(solve_thermal(to_sparse(ff, 1e-4), flux, to), Error);
}

TEST_CASE("sparse solve: an open city from the sparse pipeline, mc-hemisphere rows") {
    // city-2 (129 patches, open to the sky): the dense and the sparse run of the same method and
    // seed give the same F (the pipeline's contract), so the same temperatures.
    const Scene city = city_scene(2);
    ComputeOptions co;
    co.method = MethodKind::mc_hemisphere;
    co.method_options.samples = 2000;
    const FormFactors dense = compute_form_factors(city, co).form_factors;
    const SparseComputeResult sr = compute_sparse_form_factors(city, co, {});
    const std::size_t n = dense.size();
    PatchProperties p = grey_props(n, 0.5, 0.9);
    for (std::size_t i = 0; i < n; ++i) p.temperature[i] = 280.0 + double(i % 11) * 3.0;
    ThermalOptions to;
    to.ambient_temperature = 250.0;  // the sky
    to.solver.solver = SolverKind::direct;
    to.solver.residual = 1e-13;
    const ThermalResult ref = solve_thermal(dense, p, to);
    to.solver.solver = SolverKind::gmres;
    to.solver.residual = 1e-12;
    const ThermalResult r = solve_thermal(sr.form_factors, p, to);
    CHECK(max_rel_diff(r.net_flux, ref.net_flux) < 1e-9);
    CHECK(std::abs(r.escaped_power - ref.escaped_power) < 1e-9 * std::abs(ref.escaped_power));
}
