#pragma once
/// Dense form-factor storage and the diagnostics that every run reports (DESIGN.md, "Repair and
/// diagnostics").

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor {

/// F_ij from patch i to patch j, with the patch areas, and the standard error of each entry for
/// methods that have one. A block of rows (a row range of the pipeline) holds rows
/// [first_row, first_row + F.rows()) and every column; `areas` has every patch.
struct FormFactors {
    DenseMatrix F;
    std::vector<double> areas;
    std::optional<DenseMatrix> standard_error;
    std::size_t first_row = 0;

    /// Rows held (N for the whole matrix).
    std::size_t size() const { return static_cast<std::size_t>(F.rows()); }
    /// True when this holds only some rows of F.
    bool is_block() const { return first_row != 0 || F.rows() != F.cols(); }
};

/// What every report says about a matrix.
struct Diagnostics {
    std::size_t n = 0;
    double row_sum_min = 0, row_sum_max = 0, row_sum_mean = 0;
    /// The worst pair: max over pairs of |A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji) (0 when
    /// both are 0). A detail: two tiny entries can make it 1 (see the measures below).
    double max_reciprocity_defect = 0;
    std::size_t reciprocity_i = 0, reciprocity_j = 0;  ///< where it is largest
    /// Reciprocity of the whole matrix, area-weighted: Σ_ij |A_i F_ij − A_j F_ji| / Σ_ij A_i F_ij
    /// (0 for a matrix without exchange).
    double reciprocity_area_weighted = 0;
    /// Reciprocity relative to each row's mass: max over i of Σ_j |A_i F_ij − A_j F_ji| divided
    /// by A_i Σ_j F_ij (or by the column's Σ_j A_j F_ji when larger, so that a row computed as
    /// zeros reads 1, not infinity), at row reciprocity_row.
    double reciprocity_row_max = 0;
    std::size_t reciprocity_row = 0;
    /// With per-entry standard errors se (Monte Carlo): the defect of each pair in units of its
    /// standard error, z_ij = |A_i F_ij − A_j F_ji| / sqrt((A_i se_ij)² + (A_j se_ji)²), over the
    /// z_pairs pairs i < j whose denominator is not zero; its maximum (at z_i, z_j) and RMS.
    /// An entry estimated as 0 with standard error 0 (no sample hit) says nothing about its
    /// uncertainty: when its reverse is not 0, the standard error it would have at the reciprocal
    /// value f = A_j F_ji / A_i is used, sqrt(f (1 − f) / n_i), with n_i the row's effective
    /// sample count, the median of F_ik (1 − F_ik) / se_ik² over its entries with 0 < F_ik < 1
    /// and se_ik > 0 (the sample count of a hit-counting row); z_zero_entries counts them.
    bool has_z = false;
    std::size_t z_pairs = 0;
    double z_max = 0, z_rms = 0;
    std::size_t z_i = 0, z_j = 0;
    std::size_t z_zero_entries = 0;
    /// Pairs whose both standard errors are 0 (entries the method computed exactly) but whose
    /// relative defect exceeds 1e-9.
    std::size_t z_undefined = 0;
    std::size_t negative_entries = 0;   ///< F_ij < 0
    std::size_t entries_above_one = 0;  ///< F_ij > 1
    std::size_t nonfinite_entries = 0;  ///< NaN or Inf
    double max_abs_diagonal = 0;        ///< max |F_ii|
};

/// Computes the diagnostics of F with patch areas A, and the z-scores of reciprocity when
/// `standard_error` (the same size as F) is given.
Diagnostics diagnose(const DenseMatrix& F, const std::vector<double>& areas,
                     const DenseMatrix* standard_error = nullptr);
/// diagnose(ff.F, ff.areas, standard errors when ff has them).
Diagnostics diagnose(const FormFactors& ff);

}  // namespace formfactor
