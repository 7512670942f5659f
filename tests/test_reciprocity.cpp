// Reciprocity measured over the matrix (not the worst pair's
// max |A_i F_ij − A_j F_ji| / max(...), which is 1 for a Monte-Carlo matrix): area-weighted,
// relative to the row's mass, in units of the standard error, and the verdict against the method's
// promise.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/reciprocity.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/report.h"
#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {

// A reciprocal F (A_i F_ij symmetric) of n patches with areas 1..n; pairs with i + j a multiple
// of 4 do not see each other.
FormFactors reciprocal(int n) {
    FormFactors ff;
    ff.areas.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) ff.areas[static_cast<std::size_t>(i)] = 1.0 + i;
    DenseMatrix G = DenseMatrix::Zero(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
            if ((i + j) % 4 != 0) G(i, j) = G(j, i) = 0.02 * (1.0 + (i * 7 + j * 3) % 5);
    ff.F.resize(n, n);
    for (int i = 0; i < n; ++i) ff.F.row(i) = G.row(i) / ff.areas[static_cast<std::size_t>(i)];
    return ff;
}

}  // namespace

TEST_CASE("reciprocity: the three measures on a hand-computed matrix") {
    FormFactors ff;
    ff.areas = {1.0, 2.0, 1.0};
    ff.F.resize(3, 3);
    // A F = [[0, .2, .1], [.4, 0, .3], [.1, .3, 0]]: pair (0, 1) differs by 0.2, the rest agree.
    ff.F << 0.0, 0.2, 0.1, 0.2, 0.0, 0.15, 0.1, 0.3, 0.0;
    const Diagnostics d = diagnose(ff);
    // Σ_ij |..| = 2 · 0.2 = 0.4; Σ_ij A_i F_ij = 0.3 + 0.7 + 0.4 = 1.4.
    CHECK(d.reciprocity_area_weighted == doctest::Approx(0.4 / 1.4));
    // Row 0: 0.2 / max(0.3, 0.5) = 0.4; row 1: 0.2 / max(0.7, 0.5) = 0.2857; row 2: 0.
    CHECK(d.reciprocity_row_max == doctest::Approx(0.4));
    CHECK(d.reciprocity_row == 0u);
    CHECK(d.max_reciprocity_defect == doctest::Approx(0.5));  // the worst pair, as before
    CHECK(d.reciprocity_i == 0u);
    CHECK(d.reciprocity_j == 1u);
    CHECK_FALSE(d.has_z);
}

TEST_CASE("reciprocity: two tiny entries make the worst pair 1 but not the matrix measures") {
    FormFactors ff = reciprocal(20);
    ff.F(3, 17) = 1e-12;  // F_{17,3} stays 0: the pair's relative defect is 1
    const Diagnostics d = diagnose(ff);
    CHECK(d.max_reciprocity_defect == 1.0);
    CHECK(d.reciprocity_area_weighted < 1e-10);
    CHECK(d.reciprocity_row_max < 1e-10);
    ReciprocityPromise exact;
    exact.kind = ReciprocityPromise::Kind::exact;
    exact.tolerance = 1e-9;
    exact.method = "analytic";
    const ReciprocityVerdict v = assess_reciprocity(d, exact);
    REQUIRE(v.within);
    CHECK(*v.within);
    CHECK(v.text.find("within what analytic promises") == 0);
    // A real defect in one row breaks the promise.
    ff.F(3, 17) = 0.01;
    const ReciprocityVerdict bad = assess_reciprocity(diagnose(ff), exact);
    REQUIRE(bad.within);
    CHECK_FALSE(*bad.within);
    CHECK(bad.text.find("NOT within") == 0);
}

TEST_CASE("reciprocity: a matrix of uneven size read in strips gives the definition's measures") {
    // 150 patches (not a multiple of the strips of 64 rows nor of their steps of 8), noisy
    // entries with standard errors, a NaN, a negative entry, one above 1 and pairs tied for the
    // worst defect: the first of them in row-major order is reported, as a row-by-row scan has it.
    const int n = 150;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    FormFactors ff = reciprocal(n);
    DenseMatrix se(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            ff.F(i, j) *= 1.0 + 0.1 * (u(rng) - 0.5);
            se(i, j) = ff.F(i, j) > 0.0 ? 0.01 * ff.F(i, j) : 0.0;
        }
    ff.F(5, 140) = 0.3;  // F_{140,5} = 0: defect 1, tied with the pairs below
    ff.F(70, 90) = 0.2;
    ff.F(90, 70) = 0.0;
    ff.F(2, 149) = 0.1;
    ff.F(149, 2) = 0.0;
    ff.F(10, 11) = std::nan("");
    ff.F(12, 13) = -0.01;
    ff.F(13, 12) = -0.01 * ff.areas[12] / ff.areas[13];
    ff.F(100, 101) = 1.5;
    ff.standard_error = se;
    const Diagnostics d = diagnose(ff);
    // The definition, pair by pair.
    double worst = 0.0, z_worst = 0.0, defect_sum = 0.0, exchange = 0.0;
    std::size_t wi = 0, wj = 0, nonfinite = 0, negative = 0, above = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double f = ff.F(i, j);
            if (!std::isfinite(f)) {
                ++nonfinite;
                continue;
            }
            negative += f < 0.0;
            above += f > 1.0;
            const double a = ff.areas[std::size_t(i)] * f;
            exchange += a;
            const double g = ff.F(j, i);
            if (j <= i || !std::isfinite(g)) continue;
            const double b = ff.areas[std::size_t(j)] * g, diff = std::abs(a - b);
            defect_sum += 2.0 * diff;
            const double m = std::max(std::abs(a), std::abs(b));
            const double defect = m > 0.0 ? diff / m : 0.0;
            if (defect > worst) std::tie(worst, wi, wj) = std::tuple(defect, i, j);
            const double si = ff.areas[std::size_t(i)] * se(i, j);
            const double sj = ff.areas[std::size_t(j)] * se(j, i);
            if (si > 0.0 && sj > 0.0) z_worst = std::max(z_worst, diff / std::hypot(si, sj));
        }
    CHECK(d.max_reciprocity_defect == 1.0);
    CHECK(d.reciprocity_i == 2u);
    CHECK(d.reciprocity_j == 149u);
    CHECK(wi == d.reciprocity_i);
    CHECK(wj == d.reciprocity_j);
    CHECK(d.nonfinite_entries == nonfinite);
    CHECK(d.negative_entries == negative);
    CHECK(d.entries_above_one == above);
    CHECK(d.reciprocity_area_weighted == doctest::Approx(defect_sum / exchange).epsilon(1e-12));
    REQUIRE(d.has_z);
    CHECK(d.z_max >= z_worst);
}

TEST_CASE("reciprocity: Monte-Carlo noise of the stated size is consistent with chance") {
    const int n = 60;
    FormFactors ff = reciprocal(n);
    ff.standard_error = DenseMatrix::Zero(n, n);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> normal;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            if (i == j) continue;
            const double se = 0.05 * ff.F(i, j) + 1e-4;
            (*ff.standard_error)(i, j) = se;
            ff.F(i, j) += se * normal(rng);
        }
    ReciprocityPromise mc;
    mc.kind = ReciprocityPromise::Kind::statistical;
    mc.method = "mc-hemisphere";
    const Diagnostics d = diagnose(ff);
    REQUIRE(d.has_z);
    CHECK(d.z_pairs == static_cast<std::size_t>(n * (n - 1) / 2));
    CHECK(d.z_rms == doctest::Approx(1.0).epsilon(0.1));
    const ReciprocityVerdict v = assess_reciprocity(d, mc);
    REQUIRE(v.within);
    CHECK(*v.within);
    CHECK(v.text.find("consistent with chance") == 0);
    CHECK(v.z_max_limit > 4.0);
    CHECK(d.z_max < v.z_max_limit);
    // Standard errors four times too small (or a bias) are not chance.
    *ff.standard_error *= 0.25;
    const ReciprocityVerdict bad = assess_reciprocity(diagnose(ff), mc);
    REQUIRE(bad.within);
    CHECK_FALSE(*bad.within);
    CHECK(bad.text.find("NOT consistent with chance") == 0);
}

TEST_CASE("reciprocity: approximate and unknown methods get words, no verdict") {
    const Diagnostics d = diagnose(reciprocal(5));
    ReciprocityPromise hc;
    hc.kind = ReciprocityPromise::Kind::approximate;
    hc.method = "hemicube";
    CHECK_FALSE(assess_reciprocity(d, hc).within);
    CHECK(assess_reciprocity(d, hc).text.find("hemicube makes no reciprocity promise") == 0);
    CHECK_FALSE(assess_reciprocity(d, ReciprocityPromise{}).within);
}

TEST_CASE("reciprocity: Student and normal tails") {
    CHECK(two_sided_quantile(0.05, 0) == doctest::Approx(1.959963985).epsilon(1e-8));
    CHECK(two_sided_quantile(0.05, 15) == doctest::Approx(2.131449546).epsilon(1e-8));
    CHECK(two_sided_tail(3.0, 0) == doctest::Approx(0.002699796).epsilon(1e-6));
    CHECK(two_sided_tail(2.0, 1) == doctest::Approx(0.295167235).epsilon(1e-8));  // Cauchy
    CHECK(two_sided_quantile(1e-9, 0) == doctest::Approx(6.109410).epsilon(1e-5));
}

TEST_CASE("reciprocity: the methods' promises and the report's JSON") {
    const Scene cube = load_scene("cube");
    MethodOptions o;
    CHECK(method_traits(parse_method("analytic"), o, &cube).reciprocity.kind ==
          ReciprocityPromise::Kind::exact);
    CHECK(method_traits(parse_method("analytic"), o, &cube).reciprocity.tolerance == 1e-9);
    CHECK_FALSE(method_traits(parse_method("analytic"), o).standard_errors);
    CHECK(method_traits(parse_method("mc-hemisphere"), o).standard_errors);
    CHECK(method_traits(parse_method("mc-area"), o).reciprocity.degrees_of_freedom == 15.0);
    o.sampler = SamplerKind::random;
    CHECK(method_traits(parse_method("mc-target"), o).reciprocity.degrees_of_freedom == 15.0);
    CHECK(method_traits(parse_method("hemiplane"), o).reciprocity.kind ==
          ReciprocityPromise::Kind::approximate);
    for (const std::string& m : method_names()) CHECK_NOTHROW(method_traits(parse_method(m), o));

    ReciprocityPromise p =
        method_traits(parse_method("analytic"), MethodOptions{}, &cube).reciprocity;
    const nlohmann::json j = diagnostics_json(diagnose(reciprocal(4)), p)["reciprocity"];
    CHECK(j["max_defect"].get<double>() < 1e-15);
    CHECK(j.contains("i"));
    CHECK(j["area_weighted"].get<double>() < 1e-15);
    CHECK(j["row_relative"]["max"].get<double>() < 1e-15);
    CHECK(j["z"].is_null());
    CHECK(j["verdict"]["promise"] == "exact");
    CHECK(j["verdict"]["within"] == true);
    CHECK(j["verdict"]["tolerance"] == 1e-9);
}
