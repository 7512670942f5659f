#pragma once
/// Dense form-factor storage and the diagnostics that every run reports (DESIGN.md, "Repair and
/// diagnostics").

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor {

/// Row-major dense matrix: row i = from patch i.
using DenseMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// F_ij from patch i to patch j, with the patch areas, and the standard error of each entry for
/// methods that have one.
struct FormFactors {
    DenseMatrix F;
    std::vector<double> areas;
    std::optional<DenseMatrix> standard_error;

    std::size_t size() const { return static_cast<std::size_t>(F.rows()); }
};

/// What every report says about a matrix.
struct Diagnostics {
    std::size_t n = 0;
    double row_sum_min = 0, row_sum_max = 0, row_sum_mean = 0;
    /// max over pairs of |A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji) (0 when both are 0).
    double max_reciprocity_defect = 0;
    std::size_t reciprocity_i = 0, reciprocity_j = 0;  ///< where it is largest
    std::size_t negative_entries = 0;                  ///< F_ij < 0
    std::size_t entries_above_one = 0;                 ///< F_ij > 1
    std::size_t nonfinite_entries = 0;                 ///< NaN or Inf
    double max_abs_diagonal = 0;                       ///< max |F_ii|
};

/// Computes the diagnostics of F with patch areas A.
Diagnostics diagnose(const DenseMatrix& F, const std::vector<double>& areas);

}  // namespace formfactor
