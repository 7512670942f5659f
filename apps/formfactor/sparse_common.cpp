#include "sparse_common.h"

#include <fmt/format.h>

#include "formfactor/core/cancel.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/output/report.h"

namespace formfactor::cli {

SparseComputeResult compute_sparse_matrix(const Scene& scene, const MethodArgs& method,
                                          const RepairArgs& repair, double threshold,
                                          StepTimes& times) {
    ComputeOptions o;
    o.method = method.resolved_kind(scene);
    o.method_options = method.method_options();
    o.visibility = method.visibility;
    o.repair = repair.options(scene);
    TerminalProgress bar(cli_text);
    o.progress = &bar;
    o.cancel = &process_cancellation();
    SparseOptions so;
    so.threshold = threshold;
    // Over every MPI rank under mpirun; the pipeline's own on one process.
    SparseComputeResult r = distributed::compute_sparse_form_factors(scene, o, so);
    times.add(r.timings);
    print_rank_shares(effective_threads(o.method_options.threads));
    print_method_warnings(r.report);
    return r;
}

namespace {

nlohmann::json diagnostics_json(const SparseDiagnostics& x) {
    return nlohmann::json{{"N", x.n},
                          {"nonzeros", x.nonzeros},
                          {"row_sum_min", x.row_sum_min},
                          {"row_sum_max", x.row_sum_max},
                          {"row_sum_mean", x.row_sum_mean},
                          {"sky_factor_min", x.sky_min},
                          {"sky_factor_max", x.sky_max},
                          {"max_reciprocity_defect", x.max_reciprocity_defect},
                          {"asymmetric_entries", x.asymmetric_entries},
                          {"dropped_max", x.dropped_max},
                          {"dropped_area_weighted", x.dropped_area_weighted},
                          {"negative_entries", x.negative_entries},
                          {"entries_above_one", x.entries_above_one}};
}

nlohmann::json memory_items(const MemoryEstimate& e) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& i : e.items) j.push_back({{"what", i.what}, {"bytes", i.bytes}});
    return j;
}

}  // namespace

void add_sparse_sections(const SparseComputeResult& r, const std::string& why, double threshold,
                         const std::string& repair_mode, ReportContext& ctx) {
    const SparseFormFactors& F = r.form_factors;
    ctx.storage = {{"kind", "sparse"},
                   {"why", why},
                   {"threshold", threshold},
                   {"blocks", r.run.blocks},
                   {"block_rows", r.run.block_rows},
                   {"nonzeros", F.nonzeros()},
                   {"csr_bytes", F.memory_bytes()}};
    ctx.details = to_json(to_fields(r.report));
    ctx.diagnostics = diagnostics_json(r.diagnostics);
    ctx.memory = {{"estimate_before", memory_items(r.run.estimate_before)},
                  {"estimate_after", memory_items(r.run.estimate_after)},
                  {"projected_bytes", r.run.projected_bytes},
                  {"peak_bytes", r.run.peak_memory_bytes}};
    if (r.repair)
        ctx.repair = {{"mode", repair_mode},
                      {"closure", r.repair->closure},
                      {"entries_restored", r.repair->entries_restored},
                      {"entries_removed", r.repair->entries_removed},
                      {"rows_lowered", r.repair->rows_lowered},
                      {"min_scale", r.repair->min_scale},
                      {"closure_iterations", r.repair->closure_iterations},
                      {"closure_residual", r.repair->closure_residual},
                      {"max_row_increase", r.repair->max_row_increase},
                      {"after", diagnostics_json(r.repair->after)}};
}

void print_sparse_summary(const Scene& scene, const SparseComputeResult& r, const std::string& why,
                          double threshold, const std::string& repair_mode) {
    const SparseFormFactors& F = r.form_factors;
    const SparseDiagnostics& d = r.repair ? r.repair->after : r.diagnostics;
    const double n = static_cast<double>(F.n);
    if (r.run.blocks > 0)
        fmt::print("storage    sparse ({}); threshold {:g}, {} block{} of up to {} rows\n", why,
                   threshold, r.run.blocks, r.run.blocks == 1 ? "" : "s",
                   format_count(double(r.run.block_rows)));
    else  // read from a file
        fmt::print("storage    sparse ({}); threshold {:g}\n", why, threshold);
    fmt::print("matrix     {} stored entries ({:.1f} per row, {:.3g} % of N²), CSR {}\n",
               format_count(double(F.nonzeros())), n > 0 ? double(F.nonzeros()) / n : 0.0,
               n > 0 ? 100.0 * double(F.nonzeros()) / (n * n) : 0.0,
               format_bytes(F.memory_bytes()));
    fmt::print("dropped    max {:.3g} per row, {:.3g} area-weighted (threshold)\n",
               r.diagnostics.dropped_max, r.diagnostics.dropped_area_weighted);
    fmt::print(
        "row sums   min {:.10g}, max {:.10g}, mean {:.10g}; sky factor min {:.6g}, max {:.6g}\n",
        d.row_sum_min, d.row_sum_max, d.row_sum_mean, d.sky_min, d.sky_max);
    fmt::print("reciprocity max defect {:.3g}, {} entries without their reverse\n",
               d.max_reciprocity_defect, d.asymmetric_entries);
    warn_if_nothing_seen(scene, d.row_sum_max);
    if (r.repair)
        fmt::print(
            "repair     {}: {} reverse entries restored, {} rows lowered, closure residual "
            "{:.3g}\n",
            repair_mode, r.repair->entries_restored, r.repair->rows_lowered,
            r.repair->closure_residual);
    if (r.run.blocks > 0)
        fmt::print("memory     estimated {} before the blocks, {} projected; peak {} (RSS)\n",
                   format_bytes(r.run.estimate_before.total()), format_bytes(r.run.projected_bytes),
                   format_bytes(r.run.peak_memory_bytes));
    else
        fmt::print("memory     peak {} (RSS)\n", format_bytes(r.run.peak_memory_bytes));
}

}  // namespace formfactor::cli
