#pragma once
// Checks of the properties every form-factor matrix must keep (DESIGN.md): rows that sum to 1
// in an enclosure, and reciprocity A_i F_ij = A_j F_ji.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "formfactor/matrix/form_factors.h"

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

}  // namespace formfactor::testing
