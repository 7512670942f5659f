#include <doctest/doctest.h>

#include <cmath>

#include "formfactor/core/error.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"
#include "support/fixtures.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

PatchProperties uniform_props(std::size_t n, const Rgb& rho) {
    PatchProperties p;
    p.reflectance.assign(n, rho);
    p.emission.assign(n, Rgb::Zero());
    p.emissivity.assign(n, 0.9);
    p.temperature.assign(n, std::nan(""));
    p.net_flux.assign(n, std::nan(""));
    return p;
}

double max_diff(const std::vector<Rgb>& a, const std::vector<Rgb>& b) {
    double m = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).cwiseAbs().maxCoeff());
    return m;
}

double max_abs(const std::vector<Rgb>& a) {
    double m = 0.0;
    for (const auto& v : a) m = std::max(m, v.cwiseAbs().maxCoeff());
    return m;
}

}  // namespace

TEST_CASE("solve: radiosity of a closed box, every solver agrees with the direct solve") {
    // The 1×2×3 box (unequal areas): a light on face 4, coloured walls.
    const FormFactors ff = box123_matrix();
    PatchProperties p = uniform_props(6, Rgb(0.7, 0.7, 0.7));
    p.reflectance[0] = Rgb(0.8, 0.1, 0.1);
    p.reflectance[1] = Rgb(0.1, 0.8, 0.1);
    p.reflectance[5] = Rgb(0.95, 0.5, 0.2);
    p.emission[4] = Rgb(10.0, 8.0, 6.0);
    SolverOptions o;
    o.solver = SolverKind::direct;
    o.residual = 1e-13;
    const RadiosityResult ref = solve_radiosity(ff, p, o);
    CHECK(ref.stats.residual < 1e-14);
    // B solves B = E + ρ F B: check the equation on one entry by hand.
    double fb = 0.0;
    for (int j = 0; j < 6; ++j) fb += ff.F(2, j) * ref.radiosity[std::size_t(j)][1];
    CHECK(std::abs(ref.radiosity[2][1] - 0.7 * fb) < 1e-13);
    // Closed and reciprocal to ~1e-16: emitted = absorbed + escaped (escaped ≈ 0).
    CHECK(ref.balance.relative_defect < 1e-12);
    CHECK(ref.balance.escaped.cwiseAbs().maxCoeff() < 1e-12 * ref.balance.emitted.maxCoeff());

    for (SolverKind k : {SolverKind::jacobi, SolverKind::gauss_seidel, SolverKind::shooting}) {
        CAPTURE(to_string(k));
        o.solver = k;
        o.residual = 1e-12;
        const RadiosityResult r = solve_radiosity(ff, p, o);
        CHECK(r.stats.converged);
        CHECK(r.stats.residual <= 1e-12);
        CHECK(r.stats.iterations > 1);
        // ‖B − B*‖ ≤ ‖(I − ρF)⁻¹‖ ‖r‖ ≤ ‖r‖ / (1 − ρ_max) = 20 ‖r‖ here.
        CHECK(max_diff(r.radiosity, ref.radiosity) < 1e-10 * max_abs(ref.radiosity));
    }
}

TEST_CASE("solve: radiosity of the unit cube with uniform reflectance has the closed form") {
    // Uniform ρ, emission E on every face of a closed enclosure: B = E / (1 − ρ).
    const FormFactors ff = cube_matrix();
    PatchProperties p = uniform_props(6, Rgb(0.5, 0.25, 0.9));
    for (auto& e : p.emission) e = Rgb(1.0, 2.0, 3.0);
    for (SolverKind k :
         {SolverKind::direct, SolverKind::jacobi, SolverKind::gauss_seidel, SolverKind::shooting}) {
        SolverOptions o;
        o.solver = k;
        o.residual = 1e-12;
        const RadiosityResult r = solve_radiosity(ff, p, o);
        for (const Rgb& b : r.radiosity) {
            CHECK(b[0] == doctest::Approx(2.0).epsilon(1e-11));
            CHECK(b[1] == doctest::Approx(2.0 / 0.75).epsilon(1e-11));
            CHECK(b[2] == doctest::Approx(30.0).epsilon(1e-10));
        }
    }
}

TEST_CASE("solve: iterative solvers reach their tolerance on a larger open scene") {
    const FormFactors ff = random_open_matrix(150, 7);
    PatchProperties p = uniform_props(150, Rgb(0.9, 0.6, 0.3));
    p.emission[3] = Rgb(5, 5, 5);
    p.emission[77] = Rgb(0, 1, 2);
    SolverOptions o;
    o.solver = SolverKind::direct;
    const RadiosityResult ref = solve_radiosity(ff, p, o);
    // Open scene: the energy escapes through the missing row sums, and the balance closes.
    CHECK(ref.balance.escaped.minCoeff() > 0.0);
    CHECK(ref.balance.relative_defect < 1e-12);
    for (double tol : {1e-6, 1e-10}) {
        for (SolverKind k : {SolverKind::jacobi, SolverKind::gauss_seidel, SolverKind::shooting}) {
            CAPTURE(to_string(k));
            CAPTURE(tol);
            o.solver = k;
            o.residual = tol;
            const RadiosityResult r = solve_radiosity(ff, p, o);
            CHECK(r.stats.residual <= tol);
            // ρ ≤ 0.9 and row sums ≤ 0.95: ‖(I − ρF)⁻¹‖_∞ ≤ 1 / (1 − 0.855) < 7.
            CHECK(max_diff(r.radiosity, ref.radiosity) <= 7.0 * tol * max_abs(r.radiosity));
        }
    }
}

TEST_CASE("solve: Gauss-Seidel needs fewer sweeps than Jacobi") {
    const FormFactors ff = cube_matrix();
    PatchProperties p = uniform_props(6, Rgb(0.9, 0.9, 0.9));
    p.emission[0] = Rgb(1, 1, 1);
    SolverOptions o;
    o.solver = SolverKind::jacobi;
    const auto j = solve_radiosity(ff, p, o);
    o.solver = SolverKind::gauss_seidel;
    const auto g = solve_radiosity(ff, p, o);
    CHECK(g.stats.iterations < j.stats.iterations);
}

TEST_CASE("solve: non-convergence is an error, or a warning when allowed") {
    const FormFactors ff = cube_matrix();
    PatchProperties p = uniform_props(6, Rgb(0.9, 0.9, 0.9));
    p.emission[0] = Rgb(1, 1, 1);
    SolverOptions o;
    o.solver = SolverKind::jacobi;
    o.max_iterations = 3;
    CHECK_THROWS_WITH_AS(solve_radiosity(ff, p, o), doctest::Contains("did not converge in 3"),
                         Error);
    // Options by their library names (the CLI maps them to its flags), no flag of the CLI.
    CHECK_THROWS_WITH_AS(solve_radiosity(ff, p, o), doctest::Contains("raise `max_iterations`"),
                         Error);
    o.fail_if_not_converged = false;
    const auto r = solve_radiosity(ff, p, o);
    CHECK_FALSE(r.stats.converged);
    CHECK(r.stats.iterations == 3);
    REQUIRE(r.stats.warnings.size() == 1);
    CHECK(r.stats.residual > o.residual);
}

TEST_CASE("solve: shooting's ambient term previews the unshot light") {
    // After a few shots, adding the ambient term brings the estimate closer to the answer
    // (Cohen et al. 1988): uniform ρ makes the ambient estimate exact for the cube.
    const FormFactors ff = cube_matrix();
    PatchProperties p = uniform_props(6, Rgb(0.8, 0.8, 0.8));
    p.emission[0] = Rgb(1, 1, 1);
    SolverOptions o;
    o.solver = SolverKind::direct;
    const auto ref = solve_radiosity(ff, p, o);
    o.solver = SolverKind::shooting;
    o.max_iterations = 4;
    o.fail_if_not_converged = false;
    const auto plain = solve_radiosity(ff, p, o);
    o.add_ambient = true;
    const auto amb = solve_radiosity(ff, p, o);
    REQUIRE(amb.stats.ambient.size() == 3);
    CHECK(amb.stats.ambient[0] > 0.0);
    CHECK(max_diff(amb.radiosity, ref.radiosity) < 0.5 * max_diff(plain.radiosity, ref.radiosity));
}

TEST_CASE("solve: bad sizes and parameters are errors") {
    const FormFactors ff = cube_matrix();
    PatchProperties p = uniform_props(5, Rgb(0.5, 0.5, 0.5));
    CHECK_THROWS_WITH_AS(solve_radiosity(ff, p), doctest::Contains("5 patches"), Error);
    p = uniform_props(6, Rgb(0.5, 0.5, 0.5));
    p.reflectance[2][1] = 1.0;
    CHECK_THROWS_AS(solve_radiosity(ff, p), GeometryError);
    p.reflectance[2][1] = 0.5;
    SolverOptions o;
    o.residual = 0.0;
    CHECK_THROWS_AS(solve_radiosity(ff, p, o), OptionError);
    CHECK(parse_solver("gauss-seidel") == SolverKind::gauss_seidel);
    CHECK_THROWS_AS(parse_solver("sor"), OptionError);
}

// ---------------------------------------------------------------------------------------------
// Thermal

namespace {

PatchProperties thermal_props(std::size_t n) {
    PatchProperties p = uniform_props(n, Rgb(0.5, 0.5, 0.5));
    return p;
}

constexpr double kSigma = kStefanBoltzmann;

}  // namespace

TEST_CASE("thermal: two-surface enclosure, surface 1 cannot see itself (textbook formula)") {
    // Surface 1 = one face of the unit cube, surface 2 = the other five lumped into one:
    // F11 = 0, F12 = 1, F21 = A1/A2 = 1/5, F22 = 4/5. For uniform radiosity per surface the
    // exchange is q1 = σ(T1⁴ − T2⁴) / (1/ε1 + A1/A2 (1/ε2 − 1)) (Incropera eq. 13.23).
    FormFactors ff;
    ff.F.resize(2, 2);
    ff.F << 0.0, 1.0, 0.2, 0.8;
    ff.areas = {1.0, 5.0};
    const double T1 = 1000.0, T2 = 400.0, e1 = 0.8, e2 = 0.3;
    PatchProperties p = thermal_props(2);
    p.emissivity = {e1, e2};
    p.temperature = {T1, T2};
    const double q1 =
        kSigma * (std::pow(T1, 4) - std::pow(T2, 4)) / (1.0 / e1 + 1.0 / 5.0 * (1.0 / e2 - 1.0));
    for (SolverKind k : {SolverKind::direct, SolverKind::gauss_seidel}) {
        ThermalOptions o;
        o.solver.solver = k;
        o.solver.residual = 1e-14;
        const ThermalResult r = solve_thermal(ff, p, o);
        CHECK(r.net_flux[0] == doctest::Approx(q1).epsilon(1e-12));
        CHECK(r.net_power[1] == doctest::Approx(-q1).epsilon(1e-12));
        CHECK(std::abs(r.total_net_power) < 1e-9 * q1);
        CHECK(r.relative_balance_defect < 1e-9);
        CHECK(std::abs(r.escaped_power) < 1e-9 * q1);
    }
}

TEST_CASE("thermal: cube, face 0 against five black faces, energy balance") {
    // With ε2 = 1 the five faces have uniform radiosity σT2⁴, so the two-surface formula holds
    // patch by patch: q0 = σ(T1⁴ − T2⁴) / (1/ε1) — whatever the individual F's.
    const FormFactors ff = cube_matrix();
    PatchProperties p = thermal_props(6);
    const double T1 = 800.0, T2 = 300.0, e1 = 0.35;
    p.emissivity.assign(6, 1.0);
    p.emissivity[0] = e1;
    p.temperature.assign(6, T2);
    p.temperature[0] = T1;
    const ThermalResult r = solve_thermal(ff, p);
    const double q = e1 * kSigma * (std::pow(T1, 4) - std::pow(T2, 4));
    CHECK(r.net_flux[0] == doctest::Approx(q).epsilon(1e-12));
    // ε = 1 handled exactly: J = σT⁴.
    for (int i = 1; i < 6; ++i) CHECK(r.radiosity[std::size_t(i)] == kSigma * std::pow(T2, 4));
    // Each black face receives from face 0 in proportion to F_0i.
    CHECK(r.net_power[1] == doctest::Approx(-q * kCubeOpposite).epsilon(1e-12));
    CHECK(r.net_power[2] == doctest::Approx(-q * kCubeAdjacent).epsilon(1e-12));
    CHECK(std::abs(r.total_net_power) < 1e-9 * q);

    // All faces grey, different temperatures: Σ net_power = 0 to 1e-9.
    p.emissivity = {0.1, 0.5, 0.9, 1.0, 0.7, 0.3};
    p.temperature = {300, 350, 400, 450, 500, 1200};
    const ThermalResult g = solve_thermal(ff, p);
    double total = 0.0;
    for (double x : g.net_power) total += std::abs(x);
    CHECK(std::abs(g.total_net_power) < 1e-9 * total);
    CHECK(g.relative_balance_defect < 1e-9);
}

TEST_CASE("thermal: prescribed-flux rows give back the temperature") {
    const FormFactors ff = box123_matrix();
    PatchProperties p = thermal_props(6);
    p.emissivity = {0.2, 0.5, 0.9, 1.0, 0.7, 0.3};
    p.temperature = {300, 350, 400, 450, 500, 1200};
    const ThermalResult all_t = solve_thermal(ff, p);
    // Replace the temperatures of patches 0, 3 (ε = 1) and 5 by the fluxes found.
    PatchProperties q = p;
    for (int i : {0, 3, 5}) {
        q.temperature[std::size_t(i)] = std::nan("");
        q.net_flux[std::size_t(i)] = all_t.net_flux[std::size_t(i)];
    }
    for (SolverKind k : {SolverKind::direct, SolverKind::gauss_seidel, SolverKind::shooting}) {
        CAPTURE(to_string(k));
        ThermalOptions o;
        o.solver.solver = k;
        o.solver.residual = 1e-13;
        const ThermalResult r = solve_thermal(ff, q, o);
        for (int i = 0; i < 6; ++i) {
            CHECK(r.temperature[std::size_t(i)] ==
                  doctest::Approx(p.temperature[std::size_t(i)]).epsilon(1e-10));
            CHECK(r.radiosity[std::size_t(i)] ==
                  doctest::Approx(all_t.radiosity[std::size_t(i)]).epsilon(1e-10));
        }
        CHECK_FALSE(r.temperature_prescribed[0]);
        CHECK(r.temperature_prescribed[1]);
    }
    // Adiabatic (no T, no q): q = 0, warned.
    PatchProperties a = p;
    a.temperature[2] = std::nan("");
    const ThermalResult ad = solve_thermal(ff, a);
    CHECK(ad.net_flux[2] == 0.0);
    CHECK(ad.temperature[2] > 300.0);
    CHECK(ad.temperature[2] < 1200.0);
    REQUIRE_FALSE(ad.warnings.empty());
    CHECK(ad.warnings[0].find("adiabatic") != std::string::npos);
    // Every flux prescribed in a closed enclosure: singular, said so.
    PatchProperties s = q;
    for (int i = 0; i < 6; ++i) {
        s.temperature[std::size_t(i)] = std::nan("");
        s.net_flux[std::size_t(i)] = 0.0;
    }
    CHECK_THROWS_WITH_AS(solve_thermal(ff, s), doctest::Contains("up to a constant"), Error);
}

TEST_CASE("thermal: open scene loses heat to the environment") {
    // Two directly opposed black unit squares at distance 1 (C-11: F12 = 0.19982489569838746).
    const double f = kCubeOpposite;
    FormFactors ff;
    ff.F.resize(2, 2);
    ff.F << 0.0, f, f, 0.0;
    ff.areas = {1.0, 1.0};
    PatchProperties p = thermal_props(2);
    p.emissivity = {1.0, 1.0};
    p.temperature = {600.0, 300.0};
    ThermalOptions o;
    const ThermalResult r = solve_thermal(ff, p, o);
    const double e1 = kSigma * std::pow(600.0, 4), e2 = kSigma * std::pow(300.0, 4);
    CHECK(r.net_flux[0] == doctest::Approx(e1 - f * e2).epsilon(1e-13));
    CHECK(r.escaped_power == doctest::Approx((1 - f) * (e1 + e2)).epsilon(1e-13));
    CHECK(r.relative_balance_defect < 1e-12);
    REQUIRE_FALSE(r.warnings.empty());
    CHECK(r.warnings[0].find("open scene") != std::string::npos);
    // Environment at 300 K: patch 2 is then in equilibrium with everything but patch 1.
    o.ambient_temperature = 300.0;
    const ThermalResult a = solve_thermal(ff, p, o);
    CHECK(a.net_flux[1] == doctest::Approx(-f * (e1 - e2)).epsilon(1e-12));
    CHECK(a.net_flux[0] == doctest::Approx(e1 - e2).epsilon(1e-12));
    CHECK(a.relative_balance_defect < 1e-12);
}

TEST_CASE("thermal: Hottel's total exchange factors") {
    // Infinite parallel plates: 𝓕12 = 1 / (1/ε1 + 1/ε2 − 1).
    DenseMatrix F(2, 2);
    F << 0.0, 1.0, 1.0, 0.0;
    const DenseMatrix S = total_exchange_factors(F, {0.6, 0.25});
    CHECK(S(0, 1) == doctest::Approx(1.0 / (1.0 / 0.6 + 1.0 / 0.25 - 1.0)).epsilon(1e-14));
    CHECK(S(1, 0) == doctest::Approx(S(0, 1)).epsilon(1e-14));
    CHECK(S.row(0).sum() == doctest::Approx(0.6).epsilon(1e-14));

    // Box: Q_i = Σ_j A_i 𝓕_ij σ(T_i⁴ − T_j⁴) equals the solver's net power; reciprocity
    // A_i 𝓕_ij = A_j 𝓕_ji; rows sum to ε_i in a closed enclosure.
    const FormFactors ff = box123_matrix();
    PatchProperties p = thermal_props(6);
    p.emissivity = {0.2, 0.5, 0.9, 1.0, 0.7, 0.3};
    p.temperature = {300, 350, 400, 450, 500, 1200};
    const ThermalResult r = solve_thermal(ff, p);
    const DenseMatrix X = total_exchange_factors(ff.F, p.emissivity);
    for (int i = 0; i < 6; ++i) {
        const auto si = std::size_t(i);
        double q = 0.0;
        for (int j = 0; j < 6; ++j) {
            const auto sj = std::size_t(j);
            q += ff.areas[si] * X(i, j) * kSigma *
                 (std::pow(p.temperature[si], 4) - std::pow(p.temperature[sj], 4));
            CHECK(ff.areas[si] * X(i, j) == doctest::Approx(ff.areas[sj] * X(j, i)).epsilon(1e-12));
        }
        CHECK(q == doctest::Approx(r.net_power[si]).epsilon(1e-10));
        CHECK(X.row(i).sum() == doctest::Approx(p.emissivity[si]).epsilon(1e-13));
    }
    // Black surfaces: 𝓕 = F.
    const DenseMatrix B = total_exchange_factors(ff.F, std::vector<double>(6, 1.0));
    CHECK((B - ff.F).cwiseAbs().maxCoeff() < 1e-15);
}
