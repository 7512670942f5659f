// Per-surface aggregation of patch matrices (surface_groups, aggregate).

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/scene.h"
#include "support/files.h"

using namespace formfactor;
using formfactor::testing::data;
using formfactor::testing::write_file;

namespace {

// A random reciprocal "patch matrix": A_i F_ij = A_j F_ji = S_ij (S symmetric, positive).
FormFactors random_reciprocal(std::size_t n, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.1, 1.0);
    FormFactors f;
    f.areas.resize(n);
    for (double& a : f.areas) a = u(rng);
    f.F.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = i; j < n; ++j) {
            const double s = u(rng) * 0.01;
            f.F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = s / f.areas[i];
            f.F(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) = s / f.areas[j];
        }
    return f;
}

}  // namespace

TEST_CASE("aggregate: group rows are area-weighted means, columns sums, reciprocity kept") {
    const FormFactors f = random_reciprocal(7, 3);
    PatchGroups g;
    g.group_of_patch = {0, 0, 1, 2, 1, 0, 2};
    g.names = {"a", "b", "c"};
    const FormFactors h = aggregate(f, g);
    REQUIRE(h.size() == 3);
    CHECK_FALSE(h.standard_error.has_value());
    for (int G = 0; G < 3; ++G) {
        double area = 0.0;
        for (std::size_t i = 0; i < 7; ++i)
            if (g.group_of_patch[i] == G) area += f.areas[i];
        CHECK(h.areas[static_cast<std::size_t>(G)] == doctest::Approx(area).epsilon(1e-15));
        for (int H = 0; H < 3; ++H) {
            double s = 0.0;
            for (std::size_t i = 0; i < 7; ++i)
                for (std::size_t j = 0; j < 7; ++j)
                    if (g.group_of_patch[i] == G && g.group_of_patch[j] == H)
                        s += f.areas[i] *
                             f.F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
            CHECK(h.F(G, H) == doctest::Approx(s / area).epsilon(1e-14));
            // Reciprocity at the surface level.
            CHECK(h.areas[static_cast<std::size_t>(G)] * h.F(G, H) ==
                  doctest::Approx(h.areas[static_cast<std::size_t>(H)] * h.F(H, G)).epsilon(1e-14));
        }
    }
    // Row sums: area-weighted mean of the patch row sums.
    double weighted = 0.0;
    for (std::size_t i = 0; i < 7; ++i)
        if (g.group_of_patch[i] == 1)
            weighted += f.areas[i] * f.F.row(static_cast<Eigen::Index>(i)).sum();
    CHECK(h.F.row(1).sum() == doctest::Approx(weighted / h.areas[1]).epsilon(1e-14));
}

TEST_CASE("aggregate: standard errors combine as for independent entries") {
    FormFactors f;
    f.areas = {1.0, 3.0, 2.0};
    f.F = DenseMatrix::Zero(3, 3);
    f.F << 0.0, 0.3, 0.2, 0.1, 0.0, 0.4, 0.1, 0.6, 0.0;
    DenseMatrix se(3, 3);
    se << 0.0, 0.01, 0.02, 0.03, 0.0, 0.04, 0.05, 0.06, 0.0;
    f.standard_error = se;
    PatchGroups g;
    g.group_of_patch = {0, 0, 1};
    g.names = {"ab", "c"};
    const FormFactors h = aggregate(f, g);
    REQUIRE(h.standard_error.has_value());
    // Row ab, column c: (A_a σ_ac)² + (A_b σ_bc)² over A_ab.
    CHECK((*h.standard_error)(0, 1) ==
          doctest::Approx(std::sqrt(std::pow(1.0 * 0.02, 2) + std::pow(3.0 * 0.04, 2)) / 4.0)
              .epsilon(1e-14));
    // Row ab, column ab: four entries.
    CHECK((*h.standard_error)(0, 0) ==
          doctest::Approx(std::sqrt(std::pow(1.0 * 0.01, 2) + std::pow(3.0 * 0.03, 2)) / 4.0)
              .epsilon(1e-14));
    // Row c, column ab: σ_ca, σ_cb with weight A_c / A_c = 1.
    CHECK((*h.standard_error)(1, 0) ==
          doctest::Approx(std::sqrt(0.05 * 0.05 + 0.06 * 0.06)).epsilon(1e-14));
    CHECK(h.F(1, 0) == doctest::Approx(0.7).epsilon(1e-15));
    CHECK(h.F(0, 1) == doctest::Approx((1.0 * 0.2 + 3.0 * 0.4) / 4.0).epsilon(1e-15));
}

TEST_CASE("aggregate: bad groupings are errors") {
    const FormFactors f = random_reciprocal(3, 1);
    PatchGroups g;
    g.names = {"a", "b"};
    g.group_of_patch = {0, 1};
    CHECK_THROWS_AS(aggregate(f, g), GeometryError);  // size mismatch
    g.group_of_patch = {0, 2, 1};
    CHECK_THROWS_AS(aggregate(f, g), GeometryError);  // group out of range
    g.group_of_patch = {0, 0, 0};
    CHECK_THROWS_AS(aggregate(f, g), GeometryError);  // group b empty
}

TEST_CASE("aggregate: surface groups follow surfaces, cmb merges into the target") {
    // lshape-3.vs3: 12 surfaces; 9 and 10 are combined with 7, 11 and 12 with 8.
    Scene s = load_scene(data("lshape-3.vs3"));
    subdivide(s, {2, 0.0});
    const PatchGroups g = surface_groups(s);
    REQUIRE(g.size() == 8);
    REQUIRE(g.group_of_patch.size() == s.patches.size());
    CHECK(g.surfaces[6] == std::vector<int>{6, 8, 9});
    CHECK(g.surfaces[7] == std::vector<int>{7, 10, 11});
    CHECK(g.names[6] == "srf-7");
    CHECK(g.names[7] == "srf-8");
    for (std::size_t p = 0; p < s.patches.size(); ++p) {
        const int surf = s.patches[p].surface;
        const int expected = surf < 8 ? surf : surf < 10 ? 6 : 7;
        CHECK(g.group_of_patch[p] == expected);
    }
    // Obstructions have no group; patches keep theirs.
    const Scene o = load_scene(data("obstructed.vs3"));
    const PatchGroups go = surface_groups(o);
    CHECK(go.size() == 3);
    CHECK(go.names == std::vector<std::string>{"bottom", "top", "window"});
}

TEST_CASE("aggregate: a sparse F gives the dense per-surface matrix, dropped mass carried") {
    // The closed cube, 3 × 3 patches a face, Monte-Carlo rows (standard errors): 6 surfaces.
    Scene scene = load_scene("cube");
    subdivide(scene, SubdivisionOptions{3, 0.0});
    ComputeOptions co;
    co.method = MethodKind::mc_hemisphere;
    co.method_options.samples = 500;
    const FormFactors f = compute_form_factors(scene, co).form_factors;
    const PatchGroups groups = surface_groups(scene);
    const FormFactors dense = aggregate(f, groups);
    const SparseFormFactors sparse = aggregate(to_sparse(f), groups);
    REQUIRE(sparse.n == 6);
    sparse.check();
    REQUIRE(sparse.standard_error.has_value());
    for (std::size_t g = 0; g < 6; ++g) {
        CHECK(sparse.areas[g] == doctest::Approx(dense.areas[g]).epsilon(1e-15));
        for (std::size_t h = 0; h < 6; ++h) {
            CHECK(sparse.at(g, h) ==
                  doctest::Approx(dense.F(Eigen::Index(g), Eigen::Index(h))).epsilon(1e-14));
        }
        for (auto e = sparse.indptr[g]; e < sparse.indptr[g + 1]; ++e) {
            const auto h = static_cast<Eigen::Index>(sparse.indices[std::size_t(e)]);
            CHECK((*sparse.standard_error)[std::size_t(e)] ==
                  doctest::Approx((*dense.standard_error)(Eigen::Index(g), h)).epsilon(1e-14));
        }
    }
    // A threshold: the per-surface rows carry what their patches' rows dropped (area-weighted),
    // so stored + dropped = the computed row sums, as for the patches.
    const SparseFormFactors thr = aggregate(to_sparse(f, 0.02), groups);
    for (std::size_t g = 0; g < 6; ++g) {
        CHECK(thr.dropped[g] > 0.0);
        CHECK(thr.row_sum(g) + thr.dropped[g] ==
              doctest::Approx(dense.F.row(Eigen::Index(g)).sum()).epsilon(1e-13));
    }
    PatchGroups bad = groups;
    bad.group_of_patch[0] = 9;
    CHECK_THROWS_AS(aggregate(to_sparse(f), bad), GeometryError);
}
