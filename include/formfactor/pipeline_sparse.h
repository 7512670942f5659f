#pragma once
/// Sparse runs of the pipeline (DESIGN.md, "Scale"): F computed in blocks of rows by
/// compute_form_factors() (ComputeOptions::rows), each block thresholded into CSR as it comes,
/// so that the dense N × N matrix is never allocated (except by a method that builds it inside:
/// mc-target, which the memory estimate says).
///
///     formfactor::Scene scene = formfactor::load_scene("city-18");
///     formfactor::SparseOptions sparse{.threshold = 1e-6};
///     const formfactor::SparseComputeResult r =
///         formfactor::compute_sparse_form_factors(scene, {}, sparse);
///     // r.form_factors.values / indices / indptr: CSR of F (row i = from patch i)
///
/// Every block is bit-identical to the same rows of the whole matrix (the pipeline's contract),
/// so the stored entries are the dense matrix's entries above the threshold, bit for bit.
/// The work is that of the method on every pair: no candidate-pair culling yet (O(N²) pair
/// evaluations; the analytic method evaluates each unordered pair twice across blocks, once
/// per row, instead of once).

#include <cstddef>
#include <optional>
#include <string>

#include "formfactor/matrix/memory.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/matrix/sparse_repair.h"
#include "formfactor/pipeline.h"

namespace formfactor {

/// How compute_sparse_form_factors() stores F.
struct SparseOptions {
    /// Entries F_ij ≤ threshold are dropped (their sum kept per row); 0 keeps every positive
    /// entry.
    double threshold = 0.0;
    /// Rows per block; 0: chosen so that a block's buffers take about block_memory bytes.
    std::size_t block_rows = 0;
    /// Budget of a block's buffers when block_rows is 0; 0: min(512 MB, available memory / 4).
    double block_memory = 0.0;
};

/// How a sparse run went: blocks, memory estimated and used.
struct SparseRunReport {
    std::size_t blocks = 0;
    std::size_t block_rows = 0;
    /// The estimate made before the first block (block buffers, per-patch tables; the CSR is
    /// then unknown) and the projection after the last block (with the CSR's size).
    MemoryEstimate estimate_before, estimate_after;
    /// The largest projection of the whole run's memory made after a block (nonzeros so far
    /// extrapolated to N rows).
    double projected_bytes = 0.0;
    /// Peak resident memory of the process when the run ended (getrusage ru_maxrss: includes
    /// whatever the process held before).
    double peak_memory_bytes = 0.0;
};

/// What compute_sparse_form_factors() returns.
struct SparseComputeResult {
    /// F in CSR form (repaired when options.repair asked for it).
    SparseFormFactors form_factors;
    /// The method's report of the first block, with pairs, rays and seconds summed over the
    /// blocks and the error bound the largest of the blocks'.
    MethodReport report;
    MethodTraits traits;
    /// Of F as thresholded, before repair.
    SparseDiagnostics diagnostics;
    std::optional<SparseRepairReport> repair;
    SparseRunReport run;
    /// Wall time per step: "compute" (the blocks), "threshold" (into CSR, with the memory
    /// projection), "diagnose", "repair".
    StepTimes timings;
    int threads = 0;
};

/// Adds the report of a block of rows to the report of the blocks before it (the first block's
/// report when `first`): pairs, rays and seconds summed, the largest error bound, Monte-Carlo
/// escape counts summed. For callers that compute a matrix in blocks (the sparse run, MPI).
void merge_block_report(MethodReport& total, const MethodReport& block, bool first);

/// The form factors of scene.patches in CSR form. `options` as for compute_form_factors(),
/// except: options.rows must be every row (OptionError("rows") otherwise); options.repair
/// selects the sparse repair (formfactor/matrix/sparse_repair.h): reciprocity → the open-scene
/// rule, closure or both → closure, refused (OptionError("repair")) for a scene that is not an
/// enclosure unless options.repair.force_closure. Refuses a run whose blocks will not fit in
/// memory before computing, and stops (ResourceError) after a block when the CSR projected to
/// N rows will not fit.
SparseComputeResult compute_sparse_form_factors(const Scene& scene, const ComputeOptions& options,
                                                const SparseOptions& sparse);

/// A sparse F read from a file (read_sparse_matrix(), formfactor/output/sparse_io.h) made ready
/// for a solve of `scene`, as form_factors_from_matrix() does for a dense F: its size checked
/// against scene.patches, the areas given when the file has none (`.mtx`) or checked against
/// the scene's (relative 1e-9 of the largest: an `.h5` file of another scene or subdivision is
/// refused), diagnosed, and repaired as compute_sparse_form_factors() repairs. `source` names
/// the file in errors (InputError(source, 0, ...)). The result's report names no method and its
/// run report has no blocks.
SparseComputeResult sparse_form_factors_from_matrix(const Scene& scene, SparseFormFactors F,
                                                    const RepairOptions& repair = {},
                                                    const std::string& source = "matrix");

}  // namespace formfactor
