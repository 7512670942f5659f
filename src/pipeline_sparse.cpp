// Sparse runs: the pipeline's row blocks thresholded into CSR as they come.

#include "formfactor/pipeline_sparse.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/closure.h"
#include "formfactor/visibility/visibility.h"
#include "kernels/unobstructed.h"
#include "sparse_assembly.h"

namespace formfactor {

void merge_block_report(MethodReport& total, const MethodReport& block, bool first) {
    if (first) {
        total = block;
        return;
    }
    if (total.pairs && block.pairs) {
        total.pairs->pairs += block.pairs->pairs;
        total.pairs->zero += block.pairs->zero;
        total.pairs->exact += block.pairs->exact;
        total.pairs->far_field += block.pairs->far_field;
    }
    if (total.rays_cast && block.rays_cast) *total.rays_cast += *block.rays_cast;
    // Counts of closed-model rays and segments add up, and so does their warning; so do the
    // analytic method's far-field evaluations.
    for (const char* key : {"closed_model_escapes", "recast_rays", "rechecked_segments",
                            "segments_through_model", "far_field_kernel_evaluations"})
        if (total.details.contains(key) && block.details.contains(key))
            total.details[key] =
                total.details.at(key).unsigned_integer() + block.details.at(key).unsigned_integer();
    if (total.details.contains("closed_model_escapes")) {
        const std::uint64_t lost = total.details.at("closed_model_escapes").unsigned_integer();
        if (lost > 0) total.details["closed_model_warning"] = closed_model_escape_warning(lost);
    }
    if (total.seconds && block.seconds) *total.seconds += *block.seconds;
    if (total.error_bound_per_entry && block.error_bound_per_entry)
        total.error_bound_per_entry =
            std::max(*total.error_bound_per_entry, *block.error_bound_per_entry);
}

namespace {

// Closure is asked for (closure or both); refused for an open scene unless forced.
bool sparse_closure(const Scene& scene, const RepairOptions& repair) {
    const bool closure = repair.mode == RepairMode::closure || repair.mode == RepairMode::both;
    if (closure && !repair.force_closure && !known_enclosure(scene))
        throw OptionError("repair",
                          "closure needs a closed enclosure (this scene is open: radiation "
                          "escapes); use reciprocity, which never raises a row sum");
    return closure;
}

// The diagnosis and the repair of result.form_factors, timed.
void diagnose_and_repair(SparseComputeResult& result, const RepairOptions& repair, bool closure,
                         Stopwatch& sw) {
    announce_phase("diagnose");
    result.diagnostics = diagnose(result.form_factors);
    result.timings.add("diagnose", sw.lap());
    if (repair.mode != RepairMode::none) {
        announce_phase("repair");
        SparseRepairOptions ro;
        ro.closure = closure;
        ro.closure_tolerance = repair.closure_tolerance;
        ro.max_iterations = repair.max_iterations;
        result.repair = formfactor::repair(result.form_factors, ro);
        result.timings.add("repair", sw.lap());
    }
}

}  // namespace

SparseComputeResult sparse_form_factors_from_matrix(const Scene& scene, SparseFormFactors F,
                                                    const RepairOptions& repair,
                                                    const std::string& source) {
    const bool closure = sparse_closure(scene, repair);
    const std::size_t n = scene.patches.size();
    if (F.n != n)
        throw InputError(source, 0,
                         fmt::format("a {}x{} matrix for a scene of {} patches (same scene and "
                                     "subdivision?)",
                                     F.n, F.n, n));
    if (F.areas.empty()) {
        F.areas.resize(n);
        for (std::size_t i = 0; i < n; ++i) F.areas[i] = scene.patches[i].area;
    } else {
        double largest = 0.0;
        for (const Patch& p : scene.patches) largest = std::max(largest, p.area);
        for (std::size_t i = 0; i < n; ++i)
            if (!(std::abs(F.areas[i] - scene.patches[i].area) <= 1e-9 * largest))
                throw InputError(source, 0,
                                 fmt::format("patch {} has area {:.17g} in the file, {:.17g} in "
                                             "the scene (same scene and subdivision?)",
                                             i, F.areas[i], scene.patches[i].area));
    }
    if (F.computed_row_sums.size() != n || F.dropped.size() != n) {
        F.computed_row_sums.resize(n);
        for (std::size_t i = 0; i < n; ++i) F.computed_row_sums[i] = F.row_sum(i);
        F.dropped.assign(n, 0.0);
    }
    try {
        F.check();
    } catch (const Error& e) {
        throw InputError(source, 0, e.what());
    }
    SparseComputeResult result;
    result.form_factors = std::move(F);
    Stopwatch sw;
    diagnose_and_repair(result, repair, closure, sw);
    result.run.peak_memory_bytes = peak_memory_bytes();
    return result;
}

SparseComputeResult compute_sparse_form_factors(const Scene& scene, const ComputeOptions& options,
                                                const SparseOptions& sparse) {
    validate(options);
    const CancellationFlag& cancel = options.cancel ? *options.cancel : process_cancellation();
    cancel.throw_if_requested();
    const CancellationScope scope(cancel);
    if (!(sparse.threshold >= 0.0) || !std::isfinite(sparse.threshold))
        throw OptionError("threshold", "must be a finite number ≥ 0");
    if (!(sparse.block_memory >= 0.0) || !std::isfinite(sparse.block_memory))
        throw OptionError("block_memory", "must be a finite number of bytes ≥ 0");
    const std::size_t n = scene.patches.size();
    const RowRange rows = options.rows.clamped(n);
    if (rows.size() != n) throw OptionError("rows", "a sparse run computes every row");
    const bool closure = sparse_closure(scene, options.repair);

    SparseComputeResult result;
    const MethodKind kind = options.method ? *options.method : default_method(scene);
    result.traits = method_traits(kind, options.method_options, &scene);
    const auto method = make_method(kind);
    const bool emit_sparse = method->emits_sparse_rows(scene);
    SparseRunNeeds needs = detail::sparse_run_needs(scene, options, result.traits, emit_sparse);
    const double available = available_memory();
    double budget = sparse.block_memory;
    if (!(budget > 0.0)) budget = available > 0.0 ? std::min(512e6, available / 4) : 512e6;
    needs.block_rows = sparse.block_rows > 0
                           ? std::min(sparse.block_rows, std::max<std::size_t>(n, 1))
                           : sparse_block_rows(needs, budget);
    // Rows emitted sparse: no rows × N block. Blocks of at most 8,192 rows still keep the rows
    // waiting for the CSR small and let the projection stop a run that will not fit.
    if (emit_sparse && sparse.block_rows == 0)
        needs.block_rows = method->sparse_rows_at_once()
                               ? std::max<std::size_t>(n, 1)
                               : std::min<std::size_t>(needs.block_rows, 8192);
    result.run.block_rows = needs.block_rows;
    detail::SparseAssembly assembly(needs, sparse.threshold, options.method_options.threads);
    result.run.estimate_before = assembly.estimate_before();

    // One ray tracer for every block (a BVH of the whole scene per block was most of a
    // 10^5-patch Monte-Carlo run).
    std::unique_ptr<Visibility> visibility;
    if (!options.prebuilt_visibility && method->needs_visibility() && n > 0) {
        announce_phase("visibility");
        visibility = make_visibility(scene, options.visibility);
    }
    const Visibility* vis =
        options.prebuilt_visibility ? options.prebuilt_visibility : visibility.get();
    SparseRows emitted;
    Progress progress("sparse rows", n, options.progress);
    Stopwatch sw;
    double compute_s = 0.0, threshold_s = 0.0;
    for (std::size_t b = 0; b < n; b += needs.block_rows) {
        ComputeOptions bo = options;
        bo.rows = RowRange{b, std::min(n, b + needs.block_rows)};
        bo.repair = RepairOptions{};
        // One block (the analytic method's sparse rows come at once): the method's own phases
        // reach the sink, with its bar's time left and its note of what the partly hidden pass
        // will cost; with several, only the blocks count.
        bo.progress = needs.block_rows >= n ? options.progress : nullptr;
        bo.prebuilt_visibility = vis;
        bo.sparse_rows = emit_sparse ? &emitted : nullptr;
        ComputeResult block = compute_form_factors(scene, bo);
        compute_s += sw.lap();
        announce_phase("threshold");
        if (emit_sparse)
            assembly.add(std::move(emitted), block.form_factors.areas);
        else
            assembly.add(b, block.form_factors);
        emitted = SparseRows{};
        merge_block_report(result.report, block.report, assembly.blocks() == 1);
        result.threads = block.threads;
        threshold_s += sw.lap();
        progress.advance(bo.rows.size());
    }
    progress.finish();
    result.run.blocks = assembly.blocks();
    result.run.projected_bytes = assembly.projected_bytes();
    result.form_factors = assembly.finish();
    result.timings.add("compute", compute_s);
    result.timings.add("threshold", threshold_s);
    diagnose_and_repair(result, options.repair, closure, sw);
    needs.nonzeros = double(result.form_factors.nonzeros());
    result.run.estimate_after = estimate_sparse_memory(needs);
    result.run.peak_memory_bytes = peak_memory_bytes();
    return result;
}

namespace detail {

namespace {
// What a sparse run that will not fit can do instead (the memory message's last words).
constexpr const char* kSparseAdvice =
    "raise the threshold, use a coarser subdivision, or smaller blocks (block_rows)";
}  // namespace

SparseRunNeeds sparse_run_needs(const Scene& scene, const ComputeOptions& options,
                                const MethodTraits& traits, bool emit_sparse) {
    const MethodKind kind = options.method ? *options.method : default_method(scene);
    SparseRunNeeds needs;
    needs.patches = scene.patches.size();
    needs.standard_errors = traits.standard_errors;
    // mc-target's unobstructed values come from the analytic method's row range.
    needs.block_strip = kind == MethodKind::analytic || kind == MethodKind::mc_target;
    needs.repair = options.repair.mode != RepairMode::none;
    needs.rows_sparse = emit_sparse;
    needs.threads = effective_threads(options.method_options.threads);
    return needs;
}

SparseAssembly::SparseAssembly(const SparseRunNeeds& needs, double threshold, int threads)
    : needs_(needs),
      threshold_(threshold),
      available_(available_memory()),
      threads_(threads),
      estimate_before_(estimate_sparse_memory(needs)) {
    check_sparse_memory(needs_, available_, kSparseAdvice);
}

void SparseAssembly::start(const std::vector<double>& areas, bool standard_errors) {
    if (builder_) return;
    builder_.emplace(needs_.patches, areas, threshold_, standard_errors);
    if (lower_) {
        if (standard_errors) throw Error("sparse rows: reciprocity for rows with standard errors");
        areas_ = areas;
        lower_indices_.resize(needs_.patches);
        lower_values_.resize(needs_.patches);
    }
}

// Rows of the upper triangle made whole: each row's entries below the diagonal (in column
// order, as the rows before it were joined in order) before its own, and its own entries' lower
// counterparts kept for the rows they belong to.
void SparseAssembly::complete_rows(SparseRows& rows) {
    const std::size_t n = needs_.patches;
    if (areas_.size() != n) throw Error("sparse rows: the blocks gave no areas");
    for (std::size_t k = 0; k < rows.size(); ++k) {
        const std::size_t i = rows.first_row + k;
        std::vector<std::int32_t>& idx = rows.indices[k];
        std::vector<double>& val = rows.values[k];
        for (std::size_t e = 0; e < idx.size(); ++e) {
            const auto j = static_cast<std::size_t>(idx[e]);
            if (j <= i || j >= n) throw Error("sparse rows: an entry outside the upper triangle");
            lower_indices_[j].push_back(static_cast<std::int32_t>(i));
            lower_values_[j].push_back(reciprocal_entry(val[e], areas_[i], areas_[j]));
        }
        lower_entries_ += double(idx.size());
        std::vector<std::int32_t> whole_idx = std::move(lower_indices_[i]);
        std::vector<double> whole_val = std::move(lower_values_[i]);
        lower_entries_ -= double(whole_idx.size());
        whole_idx.insert(whole_idx.end(), idx.begin(), idx.end());
        whole_val.insert(whole_val.end(), val.begin(), val.end());
        idx = std::move(whole_idx);  // lower_*_[i] are left empty by the moves
        val = std::move(whole_val);
    }
}

void SparseAssembly::add(std::size_t first_row, const FormFactors& block) {
    ++blocks_;
    start(block.areas, block.standard_error.has_value());
    if (first_row != builder_->rows())
        throw Error(fmt::format("sparse rows: a block from row {} where row {} was due", first_row,
                                builder_->rows()));
    builder_->append(block, threads_);
    joined(-1.0);
}

void SparseAssembly::add(SparseRows rows, const std::vector<double>& areas) {
    ++blocks_;
    if (!builder_ && rows.first_row == 0) start(areas, rows.has_standard_errors());
    const std::size_t first = rows.first_row;
    if (!waiting_.emplace(first, std::move(rows)).second)
        throw Error(fmt::format("sparse rows: two blocks from row {}", first));
    join_waiting();
}

void SparseAssembly::join_waiting() {
    while (builder_ && !waiting_.empty() && waiting_.begin()->first == builder_->rows()) {
        auto node = waiting_.extract(waiting_.begin());
        if (lower_) complete_rows(node.mapped());
        // The entries a row, for the projection (the rows are released as they are appended).
        double entries = 0;
        for (const auto& row : node.mapped().values) entries += double(row.size());
        const double row_entries = entries / double(std::max<std::size_t>(node.mapped().size(), 1));
        builder_->append(std::move(node.mapped()), threads_);
        joined(row_entries);
    }
}

// The CSR so far, extrapolated to every row: stop now when it will not fit.
void SparseAssembly::joined(double row_entries) {
    ++joined_blocks_;
    SparseRunNeeds projected = needs_;
    projected.nonzeros =
        double(builder_->current().nonzeros()) * double(needs_.patches) /
            double(std::max<std::size_t>(builder_->rows(), 1)) +
        lower_entries_;  // an entry waiting for its row: as many bytes as in the CSR
    if (row_entries >= 0.0) projected.row_entries = row_entries;
    const double total = estimate_sparse_memory(projected).total();
    projected_bytes_ = std::max(projected_bytes_, total);
    check_sparse_memory(projected, available_, kSparseAdvice);
    // After the first block, room for the projection (+5 %): the arrays then grow without
    // the copies (and the doubled capacity) of repeated reallocation.
    if (joined_blocks_ == 1 && builder_->rows() < needs_.patches)
        builder_->reserve(static_cast<std::size_t>(1.05 * projected.nonzeros));
}

SparseFormFactors SparseAssembly::finish() {
    if (!builder_) {
        if (needs_.patches > 0 || !waiting_.empty())
            throw Error("sparse rows: the block of the first row is missing");
        builder_.emplace(0, std::vector<double>{}, threshold_, false);
    }
    if (!waiting_.empty())
        throw Error(fmt::format("sparse rows: rows {} to {} are missing", builder_->rows(),
                                waiting_.begin()->first));
    return builder_->finish();
}

}  // namespace detail

}  // namespace formfactor
