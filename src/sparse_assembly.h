// Rows of a sparse run joined into one CSR in row order, whatever order their blocks come in
// (one process: in order; rank 0 of an MPI job: as the ranks send them), with the run's memory
// check: the estimate of the whole run before the first block, and after each block joined the
// CSR so far extrapolated to every row.

#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/matrix/memory.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/methods/traits.h"
#include "formfactor/pipeline.h"

namespace formfactor::detail {

/// What a sparse run of `kind` on `scene` holds at its peak, but for its block rows (the
/// caller's choice): shared by the pipeline's blocks and rank 0 of an MPI job.
SparseRunNeeds sparse_run_needs(const Scene& scene, const ComputeOptions& options,
                                const MethodTraits& traits, bool emit_sparse);

class SparseAssembly {
  public:
    /// Checks `needs` against the available memory first (ResourceError).
    SparseAssembly(const SparseRunNeeds& needs, double threshold, int threads);

    /// A block of dense rows from `first_row` (FormFactors of the pipeline's row range).
    void add(std::size_t first_row, const FormFactors& block);
    /// A block of rows a method emitted sparse (or made sparse for sending).
    void add(SparseRows rows, const std::vector<double>& areas);

    /// Blocks of the upper triangle from here on (the analytic method over MPI ranks): before a
    /// row is joined, its entries below the diagonal are made by reciprocity from the entries of
    /// the rows before it, F_ji = A_i F_ij / A_j, as one process makes them
    /// (detail::reciprocal_entry()).
    void fill_lower_by_reciprocity() { lower_ = true; }

    /// Rows joined so far.
    std::size_t rows() const { return builder_ ? builder_->rows() : 0; }
    /// The CSR of every row (throws Error when a block is missing).
    SparseFormFactors finish();

    const MemoryEstimate& estimate_before() const { return estimate_before_; }
    double projected_bytes() const { return projected_bytes_; }
    /// Blocks added so far.
    std::size_t blocks() const { return blocks_; }

  private:
    void start(const std::vector<double>& areas, bool standard_errors);
    // row_entries: the entries a row of the block of emitted rows joined, −1 for dense rows.
    void joined(double row_entries);
    void join_waiting();
    void complete_rows(SparseRows& rows);

    SparseRunNeeds needs_;
    double threshold_, available_;
    int threads_;
    MemoryEstimate estimate_before_;
    double projected_bytes_ = 0.0;
    std::size_t blocks_ = 0, joined_blocks_ = 0;
    std::optional<SparseBuilder> builder_;       // made with the areas of the first block
    std::map<std::size_t, SparseRows> waiting_;  // blocks that came before the rows they follow
    // fill_lower_by_reciprocity(): per row not joined yet, its entries below the diagonal so far.
    bool lower_ = false;
    std::vector<double> areas_;
    std::vector<std::vector<std::int32_t>> lower_indices_;
    std::vector<std::vector<double>> lower_values_;
    double lower_entries_ = 0.0;
};

}  // namespace formfactor::detail
