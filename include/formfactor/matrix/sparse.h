#pragma once
/// Sparse form-factor storage (DESIGN.md, "Scale"): compressed sparse rows (CSR) of F, the
/// entries above a threshold, and per row the mass the threshold dropped, so that a repair can
/// restore reciprocity and closure without creating energy (formfactor/matrix/sparse_repair.h).
///
/// Row i holds F_ij from patch i to patch j (the same direction as the dense FormFactors), for
/// the columns indices[indptr[i]] < indices[indptr[i] + 1] < ... (ascending), 0-based. The
/// arrays are SciPy's CSR layout: scipy.sparse.csr_matrix((values, indices, indptr)).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// F in CSR form, with the areas, the computed row sums and the dropped mass of every row.
struct SparseFormFactors {
    std::size_t n = 0;                       ///< N patches: F is N × N
    std::vector<std::int64_t> indptr = {0};  ///< N + 1 offsets: row i is [indptr[i], indptr[i+1])
    std::vector<std::int32_t> indices;       ///< column j of each entry, ascending within a row
    std::vector<double> values;              ///< F_ij of each entry
    /// Standard error of each entry (Monte-Carlo methods), aligned with values.
    std::optional<std::vector<double>> standard_error;
    std::vector<double> areas;  ///< A_i of every patch
    /// Σ_j F_ij over every entry the method computed (before the threshold): the row sum that a
    /// conservative repair must not exceed in an open scene. Repair leaves it unchanged.
    std::vector<double> computed_row_sums;
    /// Per row: the mass the stored entries do not carry, computed_row_sums[i] − Σ_j F_ij. Right
    /// after the threshold, the sum of the dropped entries; after a repair, what the repair left
    /// out (0 in a closed scene).
    std::vector<double> dropped;
    /// Entries F_ij ≤ threshold were dropped (0: only zeros and negatives were dropped).
    double threshold = 0.0;

    /// Stored entries.
    std::size_t nonzeros() const { return values.size(); }
    /// Σ_j F_ij over the stored entries of row i.
    double row_sum(std::size_t i) const;
    /// The sky (escape) factor of patch i, 1 − Σ_j F_ij over the stored entries: what leaves i
    /// and reaches no patch (plus what the threshold dropped).
    double sky_factor(std::size_t i) const { return 1.0 - row_sum(i); }
    /// F_ij (0 when not stored); a binary search in row i.
    double at(std::size_t i, std::size_t j) const;
    /// Bytes held by the arrays.
    double memory_bytes() const;
    /// Throws Error when the arrays are inconsistent (sizes, offsets, unsorted or out-of-range
    /// columns, non-finite values).
    void check() const;
};

/// Rows of F as a method emits them (Method::emits_sparse_rows()), never as a dense block: rows
/// [first_row, first_row + size()), each with the entries the method computed (every non-zero,
/// before any threshold), columns ascending. Each row is written by one task, so rows may be
/// filled in parallel without locks.
struct SparseRows {
    std::size_t first_row = 0;
    std::vector<std::vector<std::int32_t>> indices;
    std::vector<std::vector<double>> values;
    /// Per row, aligned with values (Monte-Carlo methods); empty when there are none.
    std::vector<std::vector<double>> standard_error;

    /// Empties it for `rows` rows from `first` (with standard errors or not).
    void reset(std::size_t first, std::size_t rows, bool standard_errors);
    std::size_t size() const { return indices.size(); }
    bool has_standard_errors() const { return !standard_error.empty(); }
};

/// Bytes of a CSR matrix of n rows and `nonzeros` entries (with standard errors or not), with
/// its per-row arrays (areas, computed row sums, dropped mass).
double sparse_matrix_bytes(double n, double nonzeros, bool standard_errors);

/// Appends rows to a SparseFormFactors in order, keeping the entries above a threshold.
class SparseBuilder {
  public:
    /// An empty matrix of n patches with their areas; entries F_ij ≤ threshold will be dropped.
    SparseBuilder(std::size_t n, std::vector<double> areas, double threshold, bool standard_errors);
    /// Appends the rows of `block` (rows block.first_row, ... of a pipeline row range, N
    /// columns), which must follow the rows appended so far. Rows are thresholded on `threads`
    /// threads (0: all cores).
    void append(const FormFactors& block, int threads = 0);
    /// The same for rows a method emitted sparse (rows.first_row must follow the rows appended
    /// so far); only their entries are touched, never N per row.
    void append(const SparseRows& rows, int threads = 0);
    /// The same, taking the rows: each is released once it is in the matrix, so that the rows
    /// and the matrix are not both held (rows are left empty).
    void append(SparseRows&& rows, int threads = 0);
    /// Reserves room for `nonzeros` stored entries (avoids the copies of growing arrays).
    void reserve(std::size_t nonzeros);
    /// Rows appended so far.
    std::size_t rows() const { return m_.indptr.size() - 1; }
    /// The matrix (every row must have been appended; throws Error otherwise).
    SparseFormFactors finish();
    /// The matrix built so far (for memory estimates during the run).
    const SparseFormFactors& current() const { return m_; }

  private:
    SparseFormFactors m_;
};

/// CSR of a dense square matrix F (entries > threshold), for tests and small scenes.
SparseFormFactors to_sparse(const FormFactors& ff, double threshold = 0.0);

/// What a report says about a sparse matrix.
struct SparseDiagnostics {
    std::size_t n = 0, nonzeros = 0;
    double row_sum_min = 0, row_sum_max = 0, row_sum_mean = 0;  ///< stored entries
    double sky_min = 0, sky_max = 0;                            ///< 1 − row sums
    /// max over stored pairs of |A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji), an entry whose
    /// reverse is not stored counting as a defect of 1 (an asymmetric pattern).
    double max_reciprocity_defect = 0;
    std::size_t asymmetric_entries = 0;  ///< stored F_ij whose F_ji is not stored
    double dropped_max = 0;              ///< largest dropped mass of a row
    /// Σ_i A_i dropped_i / Σ_i A_i: the area-weighted share of the emitted energy dropped.
    double dropped_area_weighted = 0;
    std::size_t negative_entries = 0, entries_above_one = 0, nonfinite_entries = 0;
    std::size_t diagonal_entries = 0;  ///< stored F_ii (0 for planar patches)
};

/// Diagnoses a sparse matrix (a binary search per stored entry for its reverse).
SparseDiagnostics diagnose(const SparseFormFactors& F);

}  // namespace formfactor
