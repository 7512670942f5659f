// The rows of one block of a job, on any rank: the options a block is computed with, a kept
// job's block kept on the rank that computed it, and a worker's part of a job (ready, then a
// block per assignment until none is left).

#include <fmt/format.h>

#include <cstdlib>
#include <exception>
#include <memory>
#include <new>

#include "formfactor/core/timing.h"
#include "mpi_internal.h"

namespace formfactor::distributed {

// The options of one block of a job.
ComputeOptions block_options(const Job& job, const Visibility* visibility, RowRange rows,
                             const CancellationFlag* cancel,
                             const PartlyHiddenPairs* partly_hidden) {
    ComputeOptions o;
    o.partly_hidden = partly_hidden;
    o.method = job.method;
    o.method_options = job.method_options;
    o.visibility = job.visibility;
    o.prebuilt_visibility = visibility;
    o.rows = rows;
    o.cancel = cancel;
    o.upper_triangle_only = job.upper_only;
    return o;
}

// Computes the rows of `o` and keeps them on this rank (kept_rows()): what a kept job does with a
// block on every rank. Returns the rows' sums, then their stored entries and the largest
// dropped mass. `areas`, when not null and empty, gets the patches' areas.
std::vector<double> keep_block(const Job& job, const Scene& scene, ComputeOptions o,
                               bool emit_sparse, MethodReport& report, std::vector<double>* areas) {
    const std::size_t n = scene.patches.size();
    KeptBlock block;
    double dropped = 0.0;
    if (job.kind == JobKind::kept_sparse) {
        SparseRows emitted;
        if (emit_sparse) o.sparse_rows = &emitted;
        ComputeResult r = formfactor::compute_form_factors(scene, o);
        report = std::move(r.report);
        if (areas && areas->empty()) *areas = r.form_factors.areas;
        if (!emit_sparse) emitted = nonzero_rows(r.form_factors);
        block =
            keep_sparse(std::move(emitted), n, job.threshold, o.method_options.threads, dropped);
    } else {
        ComputeResult r = formfactor::compute_form_factors(scene, o);
        report = std::move(r.report);
        if (areas && areas->empty()) *areas = r.form_factors.areas;
        block = keep_dense(o.rows, r.form_factors.F.data(), n);
    }
    std::vector<double> out = kept_row_sums(block, n, job.kind == JobKind::kept_sparse);
    out.push_back(double(kept_entries(block, n, job.kind == JobKind::kept_sparse)));
    out.push_back(dropped);
    kept_rows().blocks.push_back(std::move(block));
    return out;
}

namespace {

// The report and rows of one block as a worker sends them (after status, rows and busy
// seconds).
void put_block(WireWriter& w, const Job& job, const Scene& scene, const Visibility* visibility,
               const PartlyHiddenPairs* partly_hidden, bool emit_sparse, RowRange rows) {
    ComputeOptions o = block_options(job, visibility, rows, &process_cancellation(), partly_hidden);
    if (keeps_rows(job.kind)) {
        MethodReport report;
        const std::vector<double> kept = keep_block(job, scene, o, emit_sparse, report);
        put_report(w, report);
        w.put_vector(kept);
        return;
    }
    if (job.kind == JobKind::sparse && emit_sparse) {
        SparseRows emitted;
        o.sparse_rows = &emitted;
        put_report(w, formfactor::compute_form_factors(scene, o).report);
        put_sparse_rows(w, emitted);
        return;
    }
    const ComputeResult r = formfactor::compute_form_factors(scene, o);
    put_report(w, r.report);
    const FormFactors& ff = r.form_factors;
    if (job.kind == JobKind::sparse) {
        put_sparse_rows(w, nonzero_rows(ff));
        return;
    }
    if (job.upper_only) {
        // Columns [rows.begin, n) only: rank 0 fills the rest (Job::upper_only).
        const auto n = static_cast<std::size_t>(ff.F.cols());
        const std::size_t b = rows.clamped(n).begin, m = static_cast<std::size_t>(ff.F.rows());
        double* upper = w.put_space<double>(m * (n - b));
        for (std::size_t k = 0; k < m; ++k)
            std::copy_n(ff.F.data() + k * n + b, n - b, upper + k * (n - b));
    } else {
        w.put_array(ff.F.data(), static_cast<std::size_t>(ff.F.size()));
    }
    w.put<std::uint8_t>(ff.standard_error.has_value());
    if (ff.standard_error)
        w.put_array(ff.standard_error->data(), static_cast<std::size_t>(ff.standard_error->size()));
}

std::vector<char> ready() {
    WireWriter w;
    w.put(Status::ready);
    return std::move(w.bytes());
}

}  // namespace

// A worker's part of one job: ready, then a block per assignment until none is left (for a job
// with a pair stage: parts of the pairs, their values from rank 0, then rows). A failure is
// sent in place of the next result, and the job then ends for this rank.
void work_on_job(const std::vector<char>& bytes) {
    Job job;
    Scene scene;
    std::unique_ptr<Visibility> visibility;
    std::unique_ptr<PartlyHiddenPairs> pairs;
    bool emit_sparse = false;
    // The message that answers work(): its own, or the failure it threw.
    auto answer = [](const auto& work) -> std::vector<char> {
        auto failed = [](Status status, const std::string& text) {
            WireWriter w;
            w.put(status);
            w.put_string(text);
            return std::move(w.bytes());
        };
        try {
            return work();
        } catch (const Cancelled& e) {
            return failed(Status::cancelled, e.what());
        } catch (const std::bad_alloc&) {
            return failed(Status::failed, kOutOfMemory);
        } catch (const std::exception& e) {
            return failed(Status::failed, e.what());
        }
    };
    std::vector<char> message = answer([&] {
        WireReader r(bytes.data(), bytes.size());
        job.kind = r.get<JobKind>();
        job.method = r.get<MethodKind>();
        job.method_options = r.get<MethodOptions>();
        job.visibility = r.get<VisibilityOptions>();
        job.threshold = r.get<double>();
        job.kept = r.get<std::uint64_t>();
        job.pairs_first = r.get<std::uint8_t>() != 0;
        job.upper_only = r.get<std::uint8_t>() != 0;
        scene = get_scene(r);
        if (keeps_rows(job.kind)) {
            kept_rows() = KeptRows{};
            kept_rows().sparse = job.kind == JobKind::kept_sparse;
            kept_rows().n = scene.patches.size();
            kept_id() = job.kept;
        }
        // For the tests of one failing rank: FORMFACTOR_TEST_FAIL_RANK=K fails rank K's jobs.
        if (const char* fail = std::getenv("FORMFACTOR_TEST_FAIL_RANK");
            fail && std::atoi(fail) == g_rank)
            throw Error(
                fmt::format("a failure injected on rank {} (FORMFACTOR_TEST_FAIL_RANK)", g_rank));
        const auto method = make_method(job.method);
        emit_sparse = sparse_job(job.kind) && method->emits_sparse_rows(scene);
        if (method->needs_visibility() && !scene.patches.empty())
            visibility = make_visibility(scene, job.visibility);
        if (job.pairs_first)  // the blockers; the classification comes in parts
            pairs = std::make_unique<PartlyHiddenPairs>(scene, job.method_options,
                                                        sparse_job(job.kind), false);
        return ready();
    });
    // Sends `message`, then a block per assignment (body(block) the message that answers it)
    // until none is left.
    auto serve_blocks = [&](const auto& body) {
        for (;;) {
            send_bytes(message, 0, kTagResult);
            wait_for(0, kTagAssign, nullptr);
            std::int64_t assign[2];
            MPI_Recv(assign, 2, MPI_INT64_T, 0, kTagAssign, g_comm, MPI_STATUS_IGNORE);
            if (assign[1] <= assign[0]) return;
            const RowRange block{std::size_t(assign[0]), std::size_t(assign[1])};
            message = answer([&] {
                Stopwatch sw;
                WireWriter w(std::move(message));  // the last message's memory, mapped already
                w.put(Status::rows);
                w.put<std::uint64_t>(block.begin);
                w.put<std::uint64_t>(block.end);
                const std::size_t seconds_at = w.bytes().size();
                w.put(0.0);
                body(block, w);
                w.patch(seconds_at, sw.seconds());
                return std::move(w.bytes());
            });
        }
    };
    if (job.pairs_first) {
        // The classification's tasks, then all of it from rank 0 (1 and its bytes; 2: too
        // large to send, classified here), or word that the job is over (0).
        serve_blocks([&](RowRange tasks, WireWriter& out) {
            if (!pairs) throw Error("distributed: the blockers are not prepared");
            out.put_vector(pairs->classify(tasks));
        });
        std::vector<char> classified = receive_bytes(wait_for(0, kTagValues, nullptr));
        if (classified.empty() || classified[0] == 0) return;
        message = answer([&] {
            if (classified[0] == 2) {
                pairs->set_classification(pairs->classify({0, pairs->classification_tasks()}));
            } else {
                pairs->set_classification(classified.data() + 1, classified.size() - 1);
            }
            classified = std::vector<char>{};
            return ready();
        });
        serve_blocks([&](RowRange part, WireWriter& out) {
            if (!pairs) throw Error("distributed: the partly hidden pairs are not classified");
            put_values(out, pairs->integrate(part));
        });
        // Every pair's values from rank 0, or word that the job is over.
        const std::vector<char> got = receive_bytes(wait_for(0, kTagValues, nullptr));
        if (got.empty() || got[0] == 0) return;
        message = answer([&] {
            WireReader r(got.data() + 1, got.size() - 1);
            pairs->set_values(get_values(r));
            return ready();
        });
    }
    serve_blocks([&](RowRange rows, WireWriter& out) {
        put_block(out, job, scene, visibility.get(), pairs.get(), emit_sparse, rows);
    });
}

}  // namespace formfactor::distributed
