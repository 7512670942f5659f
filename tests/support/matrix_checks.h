#pragma once
// Checks of the properties every form-factor matrix must keep (DESIGN.md): rows that sum to 1
// in an enclosure, and reciprocity A_i F_ij = A_j F_ji.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"

namespace formfactor::testing {

/// Every row of `F` sums to `expected` within `tolerance`.
inline void check_row_sums(const DenseMatrix& F, double expected, double tolerance) {
    for (Eigen::Index i = 0; i < F.rows(); ++i) {
        INFO("row " << i);
        CHECK(std::abs(F.row(i).sum() - expected) <= tolerance);
    }
}

/// A_i F_ij = A_j F_ji for every pair, within `tolerance` · max(A_i, A_j).
inline void check_reciprocity(const FormFactors& f, double tolerance) {
    for (Eigen::Index i = 0; i < f.F.rows(); ++i)
        for (Eigen::Index j = 0; j < i; ++j) {
            const double ai = f.areas[static_cast<std::size_t>(i)];
            const double aj = f.areas[static_cast<std::size_t>(j)];
            INFO("pair " << i << ", " << j);
            CHECK(std::abs(ai * f.F(i, j) - aj * f.F(j, i)) <= tolerance * std::max(ai, aj));
        }
}

/// The matrix of an enclosure: every row sums to 1 within `row_tolerance`, and reciprocity holds
/// within `reciprocity_tolerance` (relative, as check_reciprocity()).
inline void check_enclosure_rows(const FormFactors& f, double row_tolerance = 1e-9,
                                 double reciprocity_tolerance = 1e-10) {
    check_row_sums(f.F, 1.0, row_tolerance);
    check_reciprocity(f, reciprocity_tolerance);
}

/// The same geometry read from two files whose patches come in different orders: every patch of
/// `a` has the patch of `b` with the same centroid and normal (to 1e-12) and area, and F_a of
/// each pair equals F_b of the matched pair within `tolerance`.
inline void check_same_matrix_up_to_order(const Scene& a, const DenseMatrix& Fa, const Scene& b,
                                          const DenseMatrix& Fb, double tolerance) {
    const std::size_t n = a.patches.size();
    REQUIRE(b.patches.size() == n);
    std::vector<Eigen::Index> to_b(n, -1);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t k = 0; k < n; ++k)
            if ((a.patches[i].centroid - b.patches[k].centroid).norm() <= 1e-12 &&
                a.patches[i].normal.dot(b.patches[k].normal) >= 1 - 1e-12)
                to_b[i] = static_cast<Eigen::Index>(k);
    for (std::size_t i = 0; i < n; ++i) {
        CAPTURE(i);
        REQUIRE(to_b[i] >= 0);
        CHECK(std::abs(a.patches[i].area - b.patches[static_cast<std::size_t>(to_b[i])].area) <=
              1e-12 * a.patches[i].area);
    }
    double worst = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            worst = std::max(
                worst, std::abs(Fa(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) -
                                Fb(to_b[i], to_b[j])));
    CHECK(worst <= tolerance);
}

}  // namespace formfactor::testing
