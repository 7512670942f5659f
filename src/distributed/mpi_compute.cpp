// F computed over the ranks (compute_form_factors(), compute_sparse_form_factors(),
// compute_distributed_rows()): the memory check and block size of a job, and where rank 0 puts
// what the blocks give (the whole F, its sparse rows, or which rank keeps which rows). A solve
// of kept rows is one command (mpi_row_solve.cpp); before it, blocks of kept rows move between
// ranks to even out a product's work (mpi_row_owners.cpp).

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>

#include "formfactor/core/parallel.h"
#include "formfactor/core/timing.h"
#include "formfactor/matrix/memory.h"
#include "kernels/unobstructed.h"
#include "mpi_internal.h"
#include "sparse_assembly.h"

namespace formfactor::distributed {

namespace {

// Rows per block so that a block's buffers stay near 64 MB (`per_row` bytes a row).
std::size_t rows_for_budget(double per_row) {
    return static_cast<std::size_t>(std::max(1.0, 64e6 / std::max(per_row, 1.0)));
}

// The report of a job: rank 0's first block's, with every other block's counts added.
class ReportMerger {
  public:
    void add(const MethodReport& block) {
        const std::lock_guard lock(mutex_);
        merge_block_report(total_, block, first_);
        first_ = false;
    }
    MethodReport take() { return std::move(total_); }

  private:
    std::mutex mutex_;
    MethodReport total_;
    bool first_ = true;
};

// Rank 0's ray tracer for its own blocks: the one given, or one built when the job has gone
// out, while the other ranks build theirs.
class Rank0Visibility {
  public:
    Rank0Visibility(const Method& method, const Scene& scene, const ComputeOptions& options)
        : scene_(scene), options_(options.visibility), given_(options.prebuilt_visibility) {
        needed_ = !given_ && method.needs_visibility() && !scene.patches.empty();
    }
    void build() {
        if (!needed_ || own_) return;
        Stopwatch sw;
        own_ = make_visibility(scene_, options_);
        seconds_ = sw.seconds();
    }
    const Visibility* get() const { return given_ ? given_ : own_.get(); }
    /// Adds the build's time and the job's other time as steps "visibility" and "compute".
    void add_times(StepTimes& timings, double job_seconds) const {
        if (needed_) timings.add("visibility", seconds_);
        timings.add("compute", job_seconds - seconds_);
    }

  private:
    const Scene& scene_;
    VisibilityOptions options_;
    const Visibility* given_;
    std::unique_ptr<Visibility> own_;
    bool needed_ = false;
    double seconds_ = 0.0;
};

// What every sink of rows has: the job, and rank 0's ray tracer, built in prepare().
class RowSink : public BlockSink {
  public:
    RowSink(const Job& job, const Scene& scene, Rank0Visibility& visibility,
            const CancellationFlag& cancel)
        : job_(job), scene_(scene), visibility_(visibility), cancel_(cancel) {}
    void prepare() override { visibility_.build(); }

  protected:
    ComputeOptions options_for(const RowRange& rows) const {
        return block_options(job_, visibility_.get(), rows, &cancel_, partly_hidden);
    }

    const Job& job_;
    const Scene& scene_;

  private:
    Rank0Visibility& visibility_;
    const CancellationFlag& cancel_;
};

// Dense jobs: the rows straight into F (blocks are disjoint rows).
class DenseSink final : public RowSink {
  public:
    DenseSink(const Job& job, const Scene& scene, Rank0Visibility& visibility,
              const CancellationFlag& cancel, bool standard_errors)
        : RowSink(job, scene, visibility, cancel) {
        const auto n = static_cast<Eigen::Index>(scene.patches.size());
        ff.F = DenseMatrix::Zero(n, n);
        if (standard_errors) ff.standard_error = DenseMatrix::Zero(n, n);
    }
    void local(const RowRange& rows) override {
        ComputeResult r = formfactor::compute_form_factors(scene_, options_for(rows));
        if (ff.areas.empty()) ff.areas = r.form_factors.areas;
        place(rows, r.form_factors.F.data(), static_cast<std::size_t>(r.form_factors.F.size()),
              ff.F);
        if (ff.standard_error && r.form_factors.standard_error)
            place(rows, r.form_factors.standard_error->data(),
                  static_cast<std::size_t>(r.form_factors.standard_error->size()),
                  *ff.standard_error);
        report.add(r.report);
    }
    void remote(int from, const RowRange& rows, WireReader& r) override {
        (void)from;
        report.add(get_report(r));
        const char* data = nullptr;
        std::size_t count = r.get_array<double>(&data);
        if (job_.upper_only)
            place_upper(rows, data, count);
        else
            place(rows, data, count, ff.F);
        if (r.get<std::uint8_t>() != 0) {
            count = r.get_array<double>(&data);
            if (ff.standard_error) place(rows, data, count, *ff.standard_error);
        }
    }
    // Blocks of the upper triangle (Job::upper_only): the entries below the diagonal as one
    // process has them, by reciprocity, then the partly hidden pairs' own values.
    void finish() override {
        if (!job_.upper_only) return;
        const auto n = static_cast<std::size_t>(ff.F.rows());
        if (ff.areas.size() != n) throw Error("distributed: the blocks gave no areas");
        detail::lower_by_reciprocity(ff.F.data(), n, ff.areas, job_.method_options.threads);
        if (partly_hidden) partly_hidden->write_lower_values(ff.F);
    }

    FormFactors ff;
    ReportMerger report;

  private:
    // Columns [rows.begin, n) of the rows, as a worker sends them with Job::upper_only.
    void place_upper(const RowRange& rows, const char* data, std::size_t count) {
        const std::size_t n = scene_.patches.size(), b = rows.begin;
        if (b > n || count != rows.size() * (n - b))
            throw Error("distributed: a block of the wrong size");
        for (std::size_t k = 0; k < rows.size(); ++k)
            std::memcpy(ff.F.data() + (b + k) * n + b, data + k * (n - b) * sizeof(double),
                        (n - b) * sizeof(double));
    }
    void place(const RowRange& rows, const void* data, std::size_t count, DenseMatrix& M) const {
        const std::size_t n = scene_.patches.size();
        if (count != rows.size() * n) throw Error("distributed: a block of the wrong size");
        std::memcpy(M.data() + rows.begin * n, data, count * sizeof(double));
    }
};

// Sparse jobs: each block's sparse rows joined into the CSR as soon as the rows before it are
// in (rank 0's first block comes first: it gives the areas), with the run's memory check.
class SparseSink final : public RowSink {
  public:
    SparseSink(const Job& job, const Scene& scene, Rank0Visibility& visibility,
               const CancellationFlag& cancel, bool emit_sparse, detail::SparseAssembly& assembly)
        : RowSink(job, scene, visibility, cancel), emit_sparse_(emit_sparse), assembly_(assembly) {}
    void local(const RowRange& rows) override {
        ComputeOptions o = options_for(rows);
        SparseRows emitted;
        if (emit_sparse_) o.sparse_rows = &emitted;
        ComputeResult r = formfactor::compute_form_factors(scene_, o);
        if (!emit_sparse_) emitted = nonzero_rows(r.form_factors);
        report.add(r.report);
        add(std::move(emitted), r.form_factors.areas);
    }
    void remote(int from, const RowRange& rows, WireReader& r) override {
        (void)from;
        report.add(get_report(r));
        SparseRows got = get_sparse_rows(r);
        if (got.first_row != rows.begin || got.size() != rows.size())
            throw Error("distributed: a block of the wrong rows");
        add(std::move(got), {});
    }

    ReportMerger report;

  private:
    void add(SparseRows rows, const std::vector<double>& areas) {
        const std::lock_guard lock(mutex_);
        assembly_.add(std::move(rows), areas);
    }

    bool emit_sparse_;
    detail::SparseAssembly& assembly_;
    std::mutex mutex_;
};

// Kept jobs: rank 0 keeps its own blocks as every rank does, and learns from every block which
// rank keeps it and its row sums.
class KeptSink final : public RowSink {
  public:
    KeptSink(const Job& job, const Scene& scene, Rank0Visibility& visibility,
             const CancellationFlag& cancel, bool emit_sparse)
        : RowSink(job, scene, visibility, cancel), emit_sparse_(emit_sparse) {
        owners.resize(static_cast<std::size_t>(g_size));
        row_sums.assign(scene.patches.size(), 0.0);
    }
    void local(const RowRange& rows) override {
        const ComputeOptions o = options_for(rows);
        MethodReport block_report;
        const std::vector<double> got =
            keep_block(job_, scene_, o, emit_sparse_, block_report, &areas);
        report.add(block_report);
        record(0, rows, got);
    }
    void remote(int from, const RowRange& rows, WireReader& r) override {
        report.add(get_report(r));
        record(from, rows, r.get_vector<double>());
    }

    std::vector<double> areas;
    ReportMerger report;
    Owners owners;
    /// Per block kept: the work of a product with it (rows + stored entries), by first row.
    std::map<std::size_t, double> weights;
    std::vector<double> row_sums;
    double entries = 0.0, dropped_max = 0.0;

  private:
    void record(int from, const RowRange& rows, const std::vector<double>& got) {
        if (got.size() != rows.size() + 2) throw Error("distributed: a block of the wrong size");
        const std::lock_guard lock(mutex_);
        std::copy(got.begin(), got.begin() + std::ptrdiff_t(rows.size()),
                  row_sums.begin() + std::ptrdiff_t(rows.begin));
        entries += got[rows.size()];
        dropped_max = std::max(dropped_max, got[rows.size() + 1]);
        owners[static_cast<std::size_t>(from)].push_back(rows);
        weights[rows.begin] = double(rows.size()) + got[rows.size()];
    }

    bool emit_sparse_;
    std::mutex mutex_;
};

}  // namespace

ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options) {
    if (g_size <= 1 || g_rank != 0) return formfactor::compute_form_factors(scene, options);
    validate(options);
    const std::size_t n = scene.patches.size();
    if (options.rows.clamped(n).size() != n || options.sparse_rows)
        throw OptionError("rows", "a distributed run computes every row, dense");
    const CancellationScope scope(options.cancel ? *options.cancel : process_cancellation());
    ComputeResult result;
    Job job;
    job.kind = JobKind::dense;
    job.method = options.method ? *options.method : default_method(scene);
    job.method_options = options.method_options;
    job.visibility = options.visibility;
    job.upper_only = job.method == MethodKind::analytic;
    result.traits = method_traits(job.method, options.method_options, &scene);
    const auto method = make_method(job.method);
    const bool strip = job.method == MethodKind::analytic || job.method == MethodKind::mc_target;
    const int per_row = (result.traits.standard_errors ? 2 : 1) + (strip ? 1 : 0);
    DenseRunNeeds needs;
    needs.patches = n;
    needs.standard_errors = result.traits.standard_errors;
    needs.repair = options.repair.mode != RepairMode::none;
    const std::size_t max_rows = rows_for_budget(double(n) * 8.0 * per_row);
    needs.output_rows = std::min(max_rows, n) * static_cast<std::size_t>(per_row);
    check_memory(needs, available_memory(), "use a coarser subdivision, or sparse storage");
    method->check(scene);

    Rank0Visibility visibility(*method, scene, options);
    // Stops rank 0's own blocks when another rank fails or the process is interrupted.
    CancellationFlag cancel;
    DenseSink sink(job, scene, visibility, cancel, result.traits.standard_errors);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    visibility.add_times(result.timings, sw.lap());
    result.form_factors = std::move(sink.ff);
    result.report = sink.report.take();
    add_shares(result.report);
    result.threads = effective_threads(options.method_options.threads);
    result.diagnostics = diagnose(result.form_factors);
    if (options.repair.mode != RepairMode::none) {
        RepairOptions ro = options.repair;
        ro.enclosure = scene.enclosure;
        result.repair = repair(result.form_factors.F, result.form_factors.areas, ro);
        result.timings.add("repair", sw.lap());
    }
    return result;
}

SparseComputeResult compute_sparse_form_factors(const Scene& scene, const ComputeOptions& options,
                                                const SparseOptions& sparse) {
    if (g_size <= 1 || g_rank != 0)
        return formfactor::compute_sparse_form_factors(scene, options, sparse);
    validate(options);
    if (!(sparse.threshold >= 0.0) || !std::isfinite(sparse.threshold))
        throw OptionError("threshold", "must be a finite number ≥ 0");
    const std::size_t n = scene.patches.size();
    if (options.rows.clamped(n).size() != n)
        throw OptionError("rows", "a sparse run computes every row");
    const bool closure =
        options.repair.mode == RepairMode::closure || options.repair.mode == RepairMode::both;
    if (closure && !scene.enclosure && !options.repair.force_closure)
        throw OptionError("repair",
                          "closure needs a closed enclosure (this scene is open: radiation "
                          "escapes); use reciprocity, which never raises a row sum");
    const CancellationScope scope(options.cancel ? *options.cancel : process_cancellation());
    Job job;
    job.kind = JobKind::sparse;
    job.method = options.method ? *options.method : default_method(scene);
    job.method_options = options.method_options;
    job.visibility = options.visibility;
    const MethodTraits traits = method_traits(job.method, options.method_options, &scene);
    const auto method = make_method(job.method);
    method->check(scene);
    const bool emit_sparse = method->emits_sparse_rows(scene);
    // The analytic method's dense rows (nothing obstructs): blocks of the upper triangle, rank 0
    // makes the rest as one process does.
    job.upper_only = job.method == MethodKind::analytic && !emit_sparse;
    const bool strip = job.method == MethodKind::analytic || job.method == MethodKind::mc_target;
    std::size_t max_rows =
        emit_sparse ? 8192
                    : rows_for_budget(double(n) * 8.0 *
                                      ((traits.standard_errors ? 2 : 1) + (strip ? 1 : 0)));
    if (sparse.block_rows > 0) max_rows = std::min(max_rows, sparse.block_rows);
    // Rank 0 holds what one process holds in a sparse run (its own block, the CSR) and the
    // blocks that came before the rows they follow.
    SparseRunNeeds needs = detail::sparse_run_needs(scene, options, traits, emit_sparse);
    needs.block_rows = std::min(max_rows, std::max<std::size_t>(n, 1));
    needs.block_strip = needs.block_strip && !job.upper_only;
    detail::SparseAssembly assembly(needs, sparse.threshold, options.method_options.threads);
    if (job.upper_only) assembly.fill_lower_by_reciprocity();

    StepTimes timings;
    Rank0Visibility visibility(*method, scene, options);
    CancellationFlag cancel;
    SparseSink sink(job, scene, visibility, cancel, emit_sparse, assembly);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    visibility.add_times(timings, sw.lap());
    SparseFormFactors F = assembly.finish();
    // Joining the blocks went on beside the blocks' work: what is left of it after them.
    timings.add("threshold", sw.lap());
    SparseComputeResult result =
        sparse_form_factors_from_matrix(scene, std::move(F), options.repair, "distributed");
    for (const auto& [step, seconds] : result.timings.steps) timings.add(step, seconds);
    result.timings = timings;
    result.report = sink.report.take();
    add_shares(result.report);
    result.traits = traits;
    result.run.blocks = g_shares.blocks;
    result.run.block_rows = g_shares.largest_block;
    result.run.estimate_before = assembly.estimate_before();
    result.run.projected_bytes = assembly.projected_bytes();
    needs.nonzeros = double(result.form_factors.nonzeros());
    result.run.estimate_after = estimate_sparse_memory(needs);
    result.threads = effective_threads(options.method_options.threads);
    return result;
}

DistributedRows compute_distributed_rows(const Scene& scene, const ComputeOptions& options,
                                         const SparseOptions* sparse) {
    if (g_size <= 1 || g_rank != 0) return compute_rows_here(scene, options, sparse);
    validate(options);
    if (options.repair.mode != RepairMode::none)
        throw OptionError("repair", "needs the whole F on one process, not rows kept apart");
    const std::size_t n = scene.patches.size();
    if (options.rows.clamped(n).size() != n || options.sparse_rows)
        throw OptionError("rows", "a distributed run computes every row");
    if (sparse && (!(sparse->threshold >= 0.0) || !std::isfinite(sparse->threshold)))
        throw OptionError("threshold", "must be a finite number ≥ 0");
    const CancellationScope scope(options.cancel ? *options.cancel : process_cancellation());
    DistributedRows out;
    Job job;
    job.kind = sparse ? JobKind::kept_sparse : JobKind::kept_dense;
    job.method = options.method ? *options.method : default_method(scene);
    job.method_options = options.method_options;
    job.visibility = options.visibility;
    job.threshold = sparse ? sparse->threshold : 0.0;
    job.kept = ++kept_id();
    out.traits = method_traits(job.method, options.method_options, &scene);
    const auto method = make_method(job.method);
    method->check(scene);
    const bool emit_sparse = sparse && method->emits_sparse_rows(scene);
    const bool strip = job.method == MethodKind::analytic || job.method == MethodKind::mc_target;
    std::size_t max_rows =
        emit_sparse ? 8192
                    : rows_for_budget(double(n) * 8.0 *
                                      ((out.traits.standard_errors ? 2 : 1) + (strip ? 1 : 0)));
    if (sparse && sparse->block_rows > 0) max_rows = std::min(max_rows, sparse->block_rows);
    kept_rows() = KeptRows{};
    kept_rows().sparse = sparse != nullptr;
    kept_rows().n = n;
    Rank0Visibility visibility(*method, scene, options);
    CancellationFlag cancel;
    KeptSink sink(job, scene, visibility, cancel, emit_sparse);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    visibility.add_times(out.timings, sw.lap());
    // Even out the work of a product: blocks move between ranks, never through rank 0.
    Owners owners = std::move(sink.owners);
    const std::vector<Move> moves = balancing_moves(owners, sink.weights);
    if (!moves.empty()) {
        broadcast_command(kCommandMove, moves_bytes(moves));
        const std::string failure = make_moves(moves);
        throw_move_failures(failure, gather_move_status(failure));
        out.timings.add("balance rows", sw.lap());
    }
    g_owners = std::move(owners);
    out.rows_per_rank.assign(static_cast<std::size_t>(g_size), 0.0);
    for (std::size_t r = 0; r < g_owners.size(); ++r)
        for (const RowRange& b : g_owners[r]) out.rows_per_rank[r] += double(b.size());
    out.sparse = sparse != nullptr;
    out.n = n;
    out.areas = std::move(sink.areas);
    out.row_sums = std::move(sink.row_sums);
    out.entries = sink.entries;
    out.dropped_max = sink.dropped_max;
    out.threshold = job.threshold;
    out.report = sink.report.take();
    add_shares(out.report);
    out.threads = effective_threads(options.method_options.threads);
    out.id = job.kept;
    return out;
}

}  // namespace formfactor::distributed
