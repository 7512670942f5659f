#include <doctest/doctest.h>

#include <random>

#include "formfactor/core/error.h"
#include "formfactor/matrix/repair.h"
#include "formfactor/output/report.h"
#include "support/fixtures.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

// Multiplies every off-diagonal entry by (1 + δ), δ uniform in [−amp, amp]: breaks both
// reciprocity and closure, as a computed matrix does.
void perturb(DenseMatrix& F, double amp, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-amp, amp);
    for (Eigen::Index i = 0; i < F.rows(); ++i)
        for (Eigen::Index j = 0; j < F.cols(); ++j)
            if (i != j) F(i, j) *= 1.0 + u(rng);
}

double max_reciprocity(const DenseMatrix& F, const std::vector<double>& A) {
    double m = 0.0;
    for (Eigen::Index i = 0; i < F.rows(); ++i)
        for (Eigen::Index j = 0; j < F.cols(); ++j)
            m = std::max(m, std::abs(A[std::size_t(i)] * F(i, j) - A[std::size_t(j)] * F(j, i)));
    return m;
}

}  // namespace

TEST_CASE("repair: reciprocity is exact after symmetrisation, rows keep their sums on average") {
    FormFactors ff = box123_matrix();
    perturb(ff.F, 1e-3, 1);
    DenseMatrix F = ff.F;
    RepairOptions o;
    o.mode = RepairMode::reciprocity;
    const RepairReport r = repair(F, ff.areas, o);
    CHECK(r.before.max_reciprocity_defect > 1e-4);
    CHECK(max_reciprocity(F, ff.areas) < 1e-15);
    CHECK(r.after.max_reciprocity_defect < 1e-15);
    CHECK(r.max_abs_change > 0.0);
    CHECK(r.max_relative_change < 1e-3);
    CHECK(r.max_relative_change > 1e-5);
    // Σ_ij A_i F_ij is unchanged by averaging A_i F_ij with A_j F_ji.
    double before = 0.0, after = 0.0;
    for (int i = 0; i < 6; ++i) {
        before += ff.areas[std::size_t(i)] * ff.F.row(i).sum();
        after += ff.areas[std::size_t(i)] * F.row(i).sum();
    }
    CHECK(after == doctest::Approx(before).epsilon(1e-14));
}

TEST_CASE("repair: closure on a perturbed closed cube closes rows to 1e-12, keeps reciprocity") {
    for (const bool box : {false, true}) {
        FormFactors ff = box ? box123_matrix() : cube_matrix();
        perturb(ff.F, 2e-3, 42);
        DenseMatrix F = ff.F;
        RepairOptions o;
        o.mode = RepairMode::both;
        o.enclosure = true;
        const RepairReport r = repair(F, ff.areas, o);
        for (int i = 0; i < 6; ++i) {
            CHECK(std::abs(F.row(i).sum() - 1.0) < 1e-12);
            CHECK(F(i, i) == 0.0);
            CHECK(F.row(i).minCoeff() >= 0.0);
        }
        CHECK(max_reciprocity(F, ff.areas) < 1e-14);
        CHECK(r.after.row_sum_min > 1.0 - 1e-12);
        CHECK(r.after.row_sum_max < 1.0 + 1e-12);
        CHECK(r.closure_iterations > 0);
        // The repair moves entries by about the perturbation, not more.
        CHECK(r.max_relative_change < 5e-3);
        // And it brings the matrix back near the exact one.
        const FormFactors exact = box ? box123_matrix() : cube_matrix();
        CHECK((F - exact.F).cwiseAbs().maxCoeff() < 2e-3);
    }
}

TEST_CASE("repair: a larger symmetric-scaled closure, with negatives and a diagonal") {
    // 40 patches: a random reciprocal matrix, closed by construction through the repair, then
    // perturbed; a negative entry and a diagonal entry are cleared.
    FormFactors ff = random_open_matrix(40, 3);
    RepairOptions o;
    o.mode = RepairMode::closure;
    o.force_closure = true;
    DenseMatrix F = ff.F;
    const RepairReport r0 = repair(F, ff.areas, o);
    CHECK_FALSE(r0.warnings.empty());  // forced closure of an open-looking matrix is warned
    perturb(F, 1e-2, 5);
    F(3, 3) = 0.01;
    F(4, 7) = -1e-4;
    o.force_closure = false;
    o.enclosure = true;
    const RepairReport r = repair(F, ff.areas, o);
    CHECK(r.diagonal_cleared);
    CHECK(r.negatives_cleared == 1);
    CHECK(F(3, 3) == 0.0);
    CHECK(F.minCoeff() >= 0.0);
    for (int i = 0; i < 40; ++i) CHECK(std::abs(F.row(i).sum() - 1.0) < 1e-12);
    CHECK(max_reciprocity(F, ff.areas) < 1e-14);
}

TEST_CASE("repair: an open scene keeps its row sums, closure is refused unless forced") {
    // Two opposed unit squares at distance 1: rows sum to 0.1998.
    FormFactors ff;
    ff.F.resize(2, 2);
    ff.F << 0.0, kCubeOpposite, kCubeOpposite * 1.01, 0.0;
    ff.areas = {1.0, 1.0};
    DenseMatrix F = ff.F;
    RepairOptions o;
    o.mode = RepairMode::both;
    CHECK_THROWS_WITH_AS(repair(F, ff.areas, o), doctest::Contains("the scene is open"),
                         OptionError);
    // The options that would do, by their library names (the CLI shows its flags).
    CHECK_THROWS_WITH_AS(
        repair(F, ff.areas, o),
        doctest::Contains("use `repair` reciprocity, or `force_closure` if the scene really is"),
        OptionError);
    CHECK(F == ff.F);  // untouched
    o.mode = RepairMode::reciprocity;
    repair(F, ff.areas, o);
    CHECK(F(0, 1) == doctest::Approx(kCubeOpposite * 1.005).epsilon(1e-15));
    CHECK(F.row(0).sum() < 0.21);
    o.mode = RepairMode::closure;
    o.force_closure = true;
    F = ff.F;
    repair(F, ff.areas, o);
    CHECK(F(0, 1) == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("repair: none reports diagnostics only, names parse") {
    FormFactors ff = cube_matrix();
    DenseMatrix F = ff.F;
    const RepairReport r = repair(F, ff.areas, {});
    CHECK(F == ff.F);
    CHECK(r.before.row_sum_min == doctest::Approx(1.0).epsilon(1e-15));
    CHECK(to_json(r)["mode"] == "none");
    CHECK(parse_repair_mode("both") == RepairMode::both);
    CHECK_THROWS_AS(parse_repair_mode("smooth"), OptionError);
}
