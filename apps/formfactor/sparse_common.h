#pragma once
// Pieces shared by `compute` and `solve` with sparse storage (formfactor/pipeline_sparse.h):
// the run with progress, its report sections and its printed summary.

#include <nlohmann/json.hpp>
#include <string>

#include "common.h"
#include "formfactor/pipeline_sparse.h"
#include "solve_common.h"

namespace formfactor::cli {

/// F of `scene` in CSR form through compute_sparse_form_factors() with the method and repair
/// options and entries ≤ threshold dropped, progress on the terminal; adds its steps to `times`.
SparseComputeResult compute_sparse_matrix(const Scene& scene, const MethodArgs& method,
                                          const RepairArgs& repair, double threshold,
                                          StepTimes& times);

/// Fills the report sections of a sparse run into `ctx`: "storage" (kind, why, threshold,
/// blocks, nonzeros, CSR bytes), "details", "diagnostics" (before repair), "memory", and
/// "repair" when it ran.
void add_sparse_sections(const SparseComputeResult& r, const std::string& why, double threshold,
                         const std::string& repair_mode, ReportContext& ctx);

/// Prints the storage, matrix, dropped-mass, row-sum, reciprocity, repair and memory lines.
void print_sparse_summary(const Scene& scene, const SparseComputeResult& r, const std::string& why,
                          double threshold, const std::string& repair_mode);

}  // namespace formfactor::cli
