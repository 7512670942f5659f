// Several MPI ranks (formfactor/distributed/distributed.h). Rank 0 broadcasts a job (the scene
// and the method's options), then a dispatcher thread hands out row blocks and receives the
// rows while rank 0's main thread computes blocks of its own; the other ranks wait in serve().
// Every message a worker sends (ready, rows, failure) is answered by one assignment: a block,
// or none (the job is over for it). Waits poll with short sleeps: a blocking MPI receive spins
// a core that the computation needs.
//
// The analytic method in a scene that may obstruct runs a job in two stages: first the partly
// hidden pairs (classified on every rank, the same list everywhere) are handed out in parts of
// the list and integrated once over the ranks; rank 0 sends every rank all their values, and
// the rows then take them (formfactor/methods/partly_hidden.h). By rows alone, a pair between
// two blocks would be integrated for each block.
//
// A solve of kept rows (compute_distributed_rows()) is a command of its own: rank 0 sends the
// system, and every rank iterates on its rows with one all-gather per product (row_solve.h);
// before it, blocks of kept rows move between ranks to even out a product's work.
//
// The hierarchical operator (build_hierarchical()) is a command of its own too: every rank
// makes the partition, computes its share of the blocks and sends the others theirs, and its
// solves hand a product's running sums from rank to rank in chunk order (hierarchical_solve.h).
// Its steps end with agree(), an all-gather of every rank's status.
//
// The file is long (over 1,000 lines) because every part of it shares the communicator, the
// rank's state and the message helpers, and MPI's headers are included by this file alone.

// The C API only: Open MPI's deprecated C++ bindings warn in every build.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1

#include <fmt/format.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <numeric>
#include <optional>
#include <thread>

#include "formfactor/core/cancel.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/timing.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/partly_hidden.h"
#include "formfactor/scene/obstruction.h"
#include "hierarchical_solve.h"
#include "row_solve.h"
#include "wire.h"

namespace formfactor::distributed {

namespace {

constexpr int kTagCommand = 1, kTagResult = 2, kTagAssign = 3, kTagMove = 4, kTagValues = 5,
              kTagChain = 6;
constexpr std::int64_t kCommandJob = 1, kCommandFinish = 2, kCommandSolve = 3, kCommandMove = 4,
                       kCommandScatter = 5, kCommandOperator = 6, kCommandOperatorSolve = 7;
// dense, sparse: the rows go to rank 0; kept_dense, kept_sparse: each rank keeps its rows
// (compute_distributed_rows()) and sends their row sums.
enum class JobKind : std::uint8_t { dense, sparse, kept_dense, kept_sparse };
enum class Status : std::uint8_t { ready, rows, failed, cancelled };
constexpr const char* kOutOfMemory =
    "out of memory: the run needed more memory than this rank's machine could give (use fewer "
    "patches, or free memory)";

bool g_active = false;  // MPI was initialised by a Session, or a Communicator is in scope
bool g_finished = false;
int g_rank = 0, g_size = 1, g_thread_level = MPI_THREAD_SINGLE;
MPI_Comm g_comm = MPI_COMM_WORLD;
RankShares g_shares;
Owners g_owners;  // rank 0: who keeps which rows of the last compute_distributed_rows()

// The environment of a process that an MPI launcher started: Open MPI's mpirun, PMIx (Open
// MPI under srun), PMI (MPICH's hydra, srun --mpi=pmi2).
bool launched_by_mpi() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(name)) return true;
    return false;
}

// Waits for a message from `source` with `tag` without spinning: probe, then sleep from 20 µs
// up to 1 ms. Throws Cancelled when `cancel` is requested meanwhile.
MPI_Status wait_for(int source, int tag, const CancellationFlag* cancel) {
    auto pause = std::chrono::microseconds(20);
    for (;;) {
        int flag = 0;
        MPI_Status status;
        MPI_Iprobe(source, tag, g_comm, &flag, &status);
        if (flag) return status;
        if (cancel) cancel->throw_if_requested();
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::microseconds(1000));
    }
}

// Waits for a non-blocking operation without spinning: test, then sleep from `first` up to
// `most`.
void complete(MPI_Request& request, std::chrono::microseconds first,
              std::chrono::microseconds most) {
    auto pause = first;
    for (int done = 0;;) {
        MPI_Test(&request, &done, MPI_STATUS_IGNORE);
        if (done) return;
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, most);
    }
}

std::vector<char> receive_bytes(const MPI_Status& probed) {
    int count = 0;
    MPI_Get_count(&probed, MPI_BYTE, &count);
    std::vector<char> bytes(static_cast<std::size_t>(count));
    MPI_Recv(bytes.data(), count, MPI_BYTE, probed.MPI_SOURCE, probed.MPI_TAG, g_comm,
             MPI_STATUS_IGNORE);
    return bytes;
}

int message_size(const std::vector<char>& bytes) {
    if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw ResourceError("distributed: a message of " + format_bytes(double(bytes.size())) +
                            " is more than MPI's 2 GB (use smaller blocks)");
    return static_cast<int>(bytes.size());
}

void send_bytes(const std::vector<char>& bytes, int dest, int tag) {
    MPI_Send(bytes.data(), message_size(bytes), MPI_BYTE, dest, tag, g_comm);
}

// What every rank needs for a job.
struct Job {
    JobKind kind = JobKind::dense;
    MethodKind method = MethodKind::analytic;
    MethodOptions method_options;
    VisibilityOptions visibility;
    double threshold = 0.0;  // kept_sparse
    std::uint64_t kept = 0;  // kept_*: the id of the rows
    // The partly hidden pairs first, over the ranks (uses_pair_stage()).
    bool pairs_first = false;
};

// The analytic method's partly hidden pairs are worth a stage of their own (the header).
bool uses_pair_stage(MethodKind method, const Scene& scene) {
    return method == MethodKind::analytic && !scene.patches.empty() &&
           formfactor::may_obstruct(scene);
}

bool keeps_rows(JobKind kind) {
    return kind == JobKind::kept_dense || kind == JobKind::kept_sparse;
}
bool sparse_job(JobKind kind) { return kind == JobKind::sparse || kind == JobKind::kept_sparse; }

std::vector<char> job_bytes(const Job& job, const Scene& scene) {
    WireWriter w;
    w.put(job.kind);
    w.put(job.method);
    w.put(job.method_options);
    w.put(job.visibility);
    w.put(job.threshold);
    w.put(job.kept);
    w.put<std::uint8_t>(job.pairs_first);
    put_scene(w, scene);
    return std::move(w.bytes());
}

// Rank 0: the job to every other rank (a command each, then one broadcast).
void broadcast_job(const std::vector<char>& bytes) {
    std::int64_t size = static_cast<std::int64_t>(message_size(bytes));  // may throw: first
    for (int r = 1; r < g_size; ++r) MPI_Send(&kCommandJob, 1, MPI_INT64_T, r, kTagCommand, g_comm);
    MPI_Bcast(&size, 1, MPI_INT64_T, 0, g_comm);
    MPI_Bcast(const_cast<char*>(bytes.data()), static_cast<int>(size), MPI_BYTE, 0, g_comm);
}

// Rank 0: a solve (kCommandSolve) or the moves of kept rows (kCommandMove) to every other rank.
void broadcast_command(std::int64_t command, const std::vector<char>& bytes) {
    std::int64_t size = static_cast<std::int64_t>(message_size(bytes));
    for (int r = 1; r < g_size; ++r) MPI_Send(&command, 1, MPI_INT64_T, r, kTagCommand, g_comm);
    MPI_Bcast(&size, 1, MPI_INT64_T, 0, g_comm);
    MPI_Bcast(const_cast<char*>(bytes.data()), static_cast<int>(size), MPI_BYTE, 0, g_comm);
}

std::vector<char> receive_job() {
    std::int64_t size = 0;
    MPI_Bcast(&size, 1, MPI_INT64_T, 0, g_comm);
    std::vector<char> bytes(static_cast<std::size_t>(size));
    MPI_Bcast(bytes.data(), static_cast<int>(size), MPI_BYTE, 0, g_comm);
    return bytes;
}

// Blocks of rows for every rank, guided: a quarter of the remaining rows spread over the ranks,
// so that blocks shrink as the rows run out and the last ones even out what costly rows (or a
// slower node) unbalanced. Rank 0 takes the first block.
class Schedule {
  public:
    /// `coarse`: at most two blocks per rank, for a method whose every call prepares the whole
    /// scene (mc-target).
    Schedule(std::size_t n, int ranks, std::size_t max_rows, bool coarse)
        : ranks_(static_cast<std::size_t>(ranks)) {
        open(n, max_rows, coarse);
    }
    /// A schedule whose rows are not known yet: not ready() until open() (or stop()).
    explicit Schedule(int ranks) : ranks_(static_cast<std::size_t>(ranks)), open_(false) {}

    void open(std::size_t n, std::size_t max_rows, bool coarse) {
        const std::lock_guard lock(mutex_);
        n_ = n;
        max_rows_ = std::max<std::size_t>(1, max_rows);
        min_rows_ = std::clamp<std::size_t>(
            coarse ? (n + 2 * ranks_ - 1) / (2 * ranks_) : n / (64 * ranks_), 1, max_rows_);
        open_ = true;
    }
    /// True when take() can answer.
    bool ready() {
        const std::lock_guard lock(mutex_);
        return open_ || stopped_;
    }

    std::optional<RowRange> take() {
        const std::lock_guard lock(mutex_);
        if (stopped_ || !open_ || next_ >= n_) return std::nullopt;
        const std::size_t rows =
            std::clamp<std::size_t>((n_ - next_) / (4 * ranks_), min_rows_, max_rows_);
        const RowRange block{next_, std::min(n_, next_ + rows)};
        next_ = block.end;
        ++blocks_;
        largest_ = std::max(largest_, block.size());
        return block;
    }
    void stop() {
        const std::lock_guard lock(mutex_);
        stopped_ = true;
    }
    std::size_t blocks() const { return blocks_; }
    std::size_t largest() const { return largest_; }

  private:
    std::mutex mutex_;
    std::size_t n_ = 0, ranks_, max_rows_ = 1, min_rows_ = 1, next_ = 0, blocks_ = 0, largest_ = 0;
    bool stopped_ = false, open_ = true;
};

// Where rank 0 puts what the blocks give.
class BlockSink {
  public:
    virtual ~BlockSink() = default;
    /// Rank 0's own block (main thread).
    virtual void local(const RowRange& rows) = 0;
    /// Rank `from`'s rows as it sent them (dispatcher thread).
    virtual void remote(int from, const RowRange& rows, WireReader& r) = 0;
    /// For local(): the partly hidden pairs of a job with a pair stage (run_job() sets it).
    const PartlyHiddenPairs* partly_hidden = nullptr;
};

// The first failure of a job, wherever it happened.
struct Failure {
    std::mutex mutex;
    std::exception_ptr local;  // rank 0's own, rethrown as it is
    int rank = -1;
    Status status = Status::failed;
    std::string message;

    bool record_remote(int from, Status s, std::string what) {
        const std::lock_guard lock(mutex);
        if (local || rank >= 0) return false;
        rank = from;
        status = s;
        message = std::move(what);
        return true;
    }
    void record_local(std::exception_ptr e) {
        const std::lock_guard lock(mutex);
        if (!local && rank < 0) local = e;
    }
    bool any() {
        const std::lock_guard lock(mutex);
        return local || rank >= 0;
    }
    [[noreturn]] void rethrow() {
        if (local) std::rethrow_exception(local);
        if (status == Status::cancelled) throw Cancelled(fmt::format("rank {}: {}", rank, message));
        throw Error(fmt::format("rank {}: {}", rank, message));
    }
};

// The dispatcher (rank 0): answers every worker until each has been told the job is over.
// `job_cancel` stops rank 0's own blocks when a worker fails or this process is interrupted.
void dispatch(Schedule& schedule, BlockSink& sink, Failure& failure, CancellationFlag& job_cancel,
              Progress& progress, std::vector<double>& rows, std::vector<double>& busy) {
    int active = g_size - 1;
    auto pause = std::chrono::microseconds(20);
    std::optional<std::chrono::steady_clock::time_point> interrupted;
    // Every message is answered by an assignment: at once, or once the schedule is ready.
    std::vector<int> waiting;
    auto answer = [&](int to) {
        const std::optional<RowRange> next = schedule.take();
        const std::int64_t assign[2] = {next ? std::int64_t(next->begin) : 0,
                                        next ? std::int64_t(next->end) : 0};
        MPI_Send(assign, 2, MPI_INT64_T, to, kTagAssign, g_comm);
        if (!next) --active;
    };
    while (active > 0) {
        if (!waiting.empty() && schedule.ready()) {
            for (int to : waiting) answer(to);
            waiting.clear();
            continue;
        }
        if (process_cancellation().requested() && !interrupted) {
            interrupted = std::chrono::steady_clock::now();
            schedule.stop();
            job_cancel.request();
        }
        // Interrupted and a worker still computes after 5 s: end the job the hard way.
        if (interrupted &&
            std::chrono::steady_clock::now() - *interrupted > std::chrono::seconds(5))
            MPI_Abort(g_comm, 130);
        int flag = 0;
        MPI_Status probed;
        MPI_Iprobe(MPI_ANY_SOURCE, kTagResult, g_comm, &flag, &probed);
        if (!flag) {
            std::this_thread::sleep_for(pause);
            pause = std::min(pause * 2, std::chrono::microseconds(1000));
            continue;
        }
        pause = std::chrono::microseconds(20);
        const int from = probed.MPI_SOURCE;
        const std::vector<char> bytes = receive_bytes(probed);
        WireReader r(bytes.data(), bytes.size());
        const auto status = r.get<Status>();
        if (status == Status::rows) {
            const RowRange block{r.get<std::uint64_t>(), r.get<std::uint64_t>()};
            busy[static_cast<std::size_t>(from)] += r.get<double>();
            rows[static_cast<std::size_t>(from)] += double(block.size());
            try {
                sink.remote(from, block, r);
                progress.advance(block.size());
            } catch (...) {
                failure.record_local(std::current_exception());
                schedule.stop();
                job_cancel.request();
            }
        } else if (status == Status::failed || status == Status::cancelled) {
            if (failure.record_remote(from, status, r.get_string())) {
                schedule.stop();
                job_cancel.request();
            }
        }
        if (schedule.ready())
            answer(from);
        else
            waiting.push_back(from);
    }
}

// Rank 0's side of one stage of a job: computes blocks beside the dispatcher until the schedule
// runs out, and answers every worker until each has been told the stage is over.
// `prepare`, when set, runs first on rank 0's main thread (the dispatcher already answering)
// and opens the schedule.
void run_stage(Schedule& schedule, BlockSink& sink, Failure& failure, CancellationFlag& job_cancel,
               Progress& progress, std::vector<double>& rows, std::vector<double>& busy,
               const std::function<void()>& prepare = {}) {
    // Rank 0's first block before any other: it gives the areas (the rows' stage).
    std::optional<RowRange> block;
    if (!prepare) block = schedule.take();
    auto compute_local = [&](bool only_first) {
        try {
            if (prepare) {
                prepare();
                block = schedule.take();
            }
            for (; block; block = only_first ? std::nullopt : schedule.take()) {
                Stopwatch sw;
                sink.local(*block);
                busy[0] += sw.seconds();
                rows[0] += double(block->size());
                progress.advance(block->size());
            }
        } catch (...) {
            failure.record_local(std::current_exception());
            schedule.stop();
        }
    };
    if (g_thread_level >= MPI_THREAD_SERIALIZED) {
        std::thread dispatcher(
            [&] { dispatch(schedule, sink, failure, job_cancel, progress, rows, busy); });
        compute_local(false);
        dispatcher.join();
    } else {  // MPI calls from one thread only: rank 0 computes its first block, then dispatches
        compute_local(true);
        dispatch(schedule, sink, failure, job_cancel, progress, rows, busy);
    }
}

void put_values(WireWriter& w, const PartlyHiddenValues& v) {
    w.put_vector(v.f);
    w.put_vector(v.back);
    w.put_vector(v.integrated);
    w.put(v.stats);
}

PartlyHiddenValues get_values(WireReader& r) {
    PartlyHiddenValues v;
    v.f = r.get_vector<double>();
    v.back = r.get_vector<double>();
    v.integrated = r.get_vector<std::uint8_t>();
    v.stats = r.get<PartlyHiddenStats>();
    if (v.back.size() != v.f.size() || v.integrated.size() != v.f.size())
        throw Error("distributed: partly hidden pairs of the wrong size");
    return v;
}

// The first stage's parts of the partly hidden pairs, by their first position.
class PairSink final : public BlockSink {
  public:
    PairSink(const PartlyHiddenPairs* pairs, const CancellationFlag& cancel)
        : pairs_(pairs), cancel_(cancel) {}
    void set_pairs(const PartlyHiddenPairs* pairs) { pairs_ = pairs; }
    void local(const RowRange& part) override {
        const CancellationScope scope(cancel_);
        PartlyHiddenValues v = pairs_->integrate(part);
        const std::lock_guard lock(mutex_);
        parts_[part.begin] = std::move(v);
    }
    void remote(int from, const RowRange& part, WireReader& r) override {
        (void)from;
        PartlyHiddenValues v = get_values(r);
        if (v.f.size() != part.size()) throw Error("distributed: a part of the wrong size");
        const std::lock_guard lock(mutex_);
        parts_[part.begin] = std::move(v);
    }
    /// Every part, in order (once every part is in).
    PartlyHiddenValues all() {
        PartlyHiddenValues out;
        for (auto& [first, v] : parts_) {
            if (first != out.f.size()) throw Error("distributed: a part of the pairs is missing");
            out.f.insert(out.f.end(), v.f.begin(), v.f.end());
            out.back.insert(out.back.end(), v.back.begin(), v.back.end());
            out.integrated.insert(out.integrated.end(), v.integrated.begin(), v.integrated.end());
            out.stats.add(v.stats);
            v = PartlyHiddenValues{};
        }
        return out;
    }

  private:
    const PartlyHiddenPairs* pairs_;
    const CancellationFlag& cancel_;
    std::mutex mutex_;
    std::map<std::size_t, PartlyHiddenValues> parts_;
};

// Rank 0: the pair stage of a job (uses_pair_stage()). Every rank classifies; the parts of the
// list go out as rows do; then every worker gets every value (or, when a rank failed, word to
// stop) and `pairs` holds them. Returns the pairs, null after a failure (recorded in `failure`).
std::unique_ptr<PartlyHiddenPairs> run_pair_stage(const Job& job, const Scene& scene,
                                                  Failure& failure, CancellationFlag& job_cancel,
                                                  ProgressSink* progress_sink) {
    std::unique_ptr<PartlyHiddenPairs> pairs;
    // Parts shrink as the pairs run out; each is a sample of the list (partly_hidden.h), so
    // its cost follows its size.
    Schedule schedule(g_size);
    PairSink sink(nullptr, job_cancel);
    std::vector<double> done(static_cast<std::size_t>(g_size), 0.0), busy = done;
    // Made again once the count is known; the dispatcher advances it only after that (it
    // answers no worker before the schedule opens).
    std::optional<Progress> progress;
    progress.emplace("partly hidden pairs", 0, nullptr);
    // Rank 0 classifies while the dispatcher takes the workers' first word (a failure stops
    // it through job_cancel).
    auto classify = [&] {
        {
            const CancellationScope scope(job_cancel);
            pairs = std::make_unique<PartlyHiddenPairs>(scene, job.method_options,
                                                        sparse_job(job.kind));
        }
        sink.set_pairs(pairs.get());
        progress.emplace("partly hidden pairs", pairs->count(), progress_sink);
        schedule.open(pairs->count(), pairs->count(), false);
    };
    run_stage(schedule, sink, failure, job_cancel, *progress, done, busy, classify);
    if (!failure.any()) progress->finish();
    progress.reset();
    std::vector<char> message(1, 0);  // 0: stop
    if (!failure.any() && !process_cancellation().requested()) {
        try {
            PartlyHiddenValues all = sink.all();
            WireWriter w;
            w.put<std::uint8_t>(1);
            put_values(w, all);
            message_size(w.bytes());  // a message MPI cannot send fails here, not in the sends
            message = std::move(w.bytes());
            pairs->set_values(std::move(all));
        } catch (...) {
            failure.record_local(std::current_exception());
            message.assign(1, 0);
        }
    }
    for (int r = 1; r < g_size; ++r) send_bytes(message, r, kTagValues);
    g_shares.pairs = done;
    g_shares.pair_blocks = schedule.blocks();
    g_shares.busy_seconds = busy;
    if (message[0] == 0) return nullptr;
    return pairs;
}

// Rank 0: broadcasts the job, (its pair stage,) then computes blocks beside the dispatcher
// until the rows run out; rethrows the first failure of any rank.
void run_job(Job job, const Scene& scene, std::size_t max_rows, BlockSink& sink,
             CancellationFlag& job_cancel, ProgressSink* progress_sink) {
    job.pairs_first = uses_pair_stage(job.method, scene);
    broadcast_job(job_bytes(job, scene));
    const std::size_t n = scene.patches.size();
    Failure failure;
    g_shares = RankShares{};
    g_shares.busy_seconds.assign(static_cast<std::size_t>(g_size), 0.0);
    std::unique_ptr<PartlyHiddenPairs> pairs;
    if (job.pairs_first) {
        pairs = run_pair_stage(job, scene, failure, job_cancel, progress_sink);
        if (!pairs) {
            if (failure.any()) failure.rethrow();
            process_cancellation().throw_if_requested();
            throw Cancelled();
        }
        sink.partly_hidden = pairs.get();
    }
    // The analytic method's blocks take the classification of the pair stage: fine blocks.
    const bool coarse = job.method == MethodKind::mc_target;
    Schedule schedule(n, g_size, max_rows, coarse);
    std::vector<double> rows(static_cast<std::size_t>(g_size), 0.0), busy = rows;
    Progress progress("rows", n, progress_sink);
    run_stage(schedule, sink, failure, job_cancel, progress, rows, busy);
    sink.partly_hidden = nullptr;
    if (failure.any()) failure.rethrow();
    process_cancellation().throw_if_requested();
    progress.finish();
    g_shares.rows = rows;
    for (std::size_t r = 0; r < busy.size(); ++r) g_shares.busy_seconds[r] += busy[r];
    g_shares.blocks = schedule.blocks();
}

// The ranks' shares in the method's report.
void add_shares(MethodReport& report) {
    if (!report.details.is_object()) report.details = Fields::object();
    Fields& mpi = report.details["mpi"];
    mpi = Fields::object();
    mpi["ranks"] = g_size;
    mpi["blocks"] = g_shares.blocks;
    mpi["rows_per_rank"] = g_shares.rows;
    mpi["busy_seconds_per_rank"] = g_shares.busy_seconds;
    mpi["imbalance"] = g_shares.imbalance();
    if (!g_shares.pairs.empty()) {
        mpi["partly_hidden_pairs_per_rank"] = g_shares.pairs;
        mpi["partly_hidden_pair_parts"] = g_shares.pair_blocks;
    }
}

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
    return o;
}

// Computes the rows of `o` and keeps them on this rank (kept_rows()): what a kept job does with a
// block on every rank. Returns the rows' sums, then their stored entries and the largest
// dropped mass. `areas`, when not null and empty, gets the patches' areas.
std::vector<double> keep_block(const Job& job, const Scene& scene, ComputeOptions o,
                               bool emit_sparse, MethodReport& report,
                               std::vector<double>* areas = nullptr) {
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

// The rows of one block as a worker sends them (after status, rows and busy seconds).
void put_block(WireWriter& w, const Job& job, const Scene& scene, const Visibility* visibility,
               const PartlyHiddenPairs* partly_hidden, bool emit_sparse, RowRange rows,
               MethodReport& report) {
    ComputeOptions o = block_options(job, visibility, rows, &process_cancellation(), partly_hidden);
    if (keeps_rows(job.kind)) {
        w.put_vector(keep_block(job, scene, o, emit_sparse, report));
        return;
    }
    if (job.kind == JobKind::sparse && emit_sparse) {
        SparseRows emitted;
        o.sparse_rows = &emitted;
        report = formfactor::compute_form_factors(scene, o).report;
        put_sparse_rows(w, emitted);
    } else if (job.kind == JobKind::sparse) {
        const ComputeResult r = formfactor::compute_form_factors(scene, o);
        report = r.report;
        put_sparse_rows(w, nonzero_rows(r.form_factors));
    } else {
        const ComputeResult r = formfactor::compute_form_factors(scene, o);
        report = r.report;
        const FormFactors& ff = r.form_factors;
        w.put_array(ff.F.data(), static_cast<std::size_t>(ff.F.size()));
        w.put<std::uint8_t>(ff.standard_error.has_value());
        if (ff.standard_error)
            w.put_array(ff.standard_error->data(),
                        static_cast<std::size_t>(ff.standard_error->size()));
    }
}

std::vector<char> ready() {
    WireWriter w;
    w.put(Status::ready);
    return std::move(w.bytes());
}

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
        if (job.pairs_first)
            pairs = std::make_unique<PartlyHiddenPairs>(scene, job.method_options,
                                                        sparse_job(job.kind));
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
                WireWriter out;
                body(block, out);
                WireWriter w;
                w.put(Status::rows);
                w.put<std::uint64_t>(block.begin);
                w.put<std::uint64_t>(block.end);
                w.put(sw.seconds());
                w.bytes().insert(w.bytes().end(), out.bytes().begin(), out.bytes().end());
                return std::move(w.bytes());
            });
        }
    };
    if (job.pairs_first) {
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
        WireWriter body;
        MethodReport report;
        put_block(body, job, scene, visibility.get(), pairs.get(), emit_sparse, rows, report);
        put_report(out, report);
        out.bytes().insert(out.bytes().end(), body.bytes().begin(), body.bytes().end());
    });
}

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

// Dense jobs: the rows straight into F (blocks are disjoint rows).
class DenseSink final : public BlockSink {
  public:
    DenseSink(const Job& job, const Scene& scene, const Visibility* visibility,
              const CancellationFlag& cancel, bool standard_errors)
        : job_(job), scene_(scene), visibility_(visibility), cancel_(cancel) {
        const auto n = static_cast<Eigen::Index>(scene.patches.size());
        ff.F = DenseMatrix::Zero(n, n);
        if (standard_errors) ff.standard_error = DenseMatrix::Zero(n, n);
    }
    void local(const RowRange& rows) override {
        ComputeResult r = formfactor::compute_form_factors(
            scene_, block_options(job_, visibility_, rows, &cancel_, partly_hidden));
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
        place(rows, data, count, ff.F);
        if (r.get<std::uint8_t>() != 0) {
            count = r.get_array<double>(&data);
            if (ff.standard_error) place(rows, data, count, *ff.standard_error);
        }
    }

    FormFactors ff;
    ReportMerger report;

  private:
    void place(const RowRange& rows, const void* data, std::size_t count, DenseMatrix& M) const {
        const std::size_t n = scene_.patches.size();
        if (count != rows.size() * n) throw Error("distributed: a block of the wrong size");
        std::memcpy(M.data() + rows.begin * n, data, count * sizeof(double));
    }

    const Job& job_;
    const Scene& scene_;
    const Visibility* visibility_;
    const CancellationFlag& cancel_;
};

// Sparse jobs: each block's sparse rows kept until all are in, then thresholded in row order.
class SparseSink final : public BlockSink {
  public:
    SparseSink(const Job& job, const Scene& scene, const Visibility* visibility,
               const CancellationFlag& cancel, bool emit_sparse)
        : job_(job),
          scene_(scene),
          visibility_(visibility),
          cancel_(cancel),
          emit_sparse_(emit_sparse) {}
    void local(const RowRange& rows) override {
        ComputeOptions o = block_options(job_, visibility_, rows, &cancel_, partly_hidden);
        SparseRows emitted;
        if (emit_sparse_) o.sparse_rows = &emitted;
        ComputeResult r = formfactor::compute_form_factors(scene_, o);
        if (areas.empty()) areas = r.form_factors.areas;
        if (!emit_sparse_) emitted = nonzero_rows(r.form_factors);
        report.add(r.report);
        const std::lock_guard lock(mutex_);
        blocks[rows.begin] = std::move(emitted);
    }
    void remote(int from, const RowRange& rows, WireReader& r) override {
        (void)from;
        report.add(get_report(r));
        SparseRows got = get_sparse_rows(r);
        if (got.first_row != rows.begin || got.size() != rows.size())
            throw Error("distributed: a block of the wrong rows");
        const std::lock_guard lock(mutex_);
        blocks[rows.begin] = std::move(got);
    }

    std::vector<double> areas;
    std::map<std::size_t, SparseRows> blocks;
    ReportMerger report;

  private:
    const Job& job_;
    const Scene& scene_;
    const Visibility* visibility_;
    const CancellationFlag& cancel_;
    bool emit_sparse_;
    std::mutex mutex_;
};

// Kept jobs: rank 0 keeps its own blocks as every rank does, and learns from every block which
// rank keeps it and its row sums.
class KeptSink final : public BlockSink {
  public:
    KeptSink(const Job& job, const Scene& scene, const Visibility* visibility,
             const CancellationFlag& cancel, bool emit_sparse)
        : job_(job),
          scene_(scene),
          visibility_(visibility),
          cancel_(cancel),
          emit_sparse_(emit_sparse) {
        owners.resize(static_cast<std::size_t>(g_size));
        row_sums.assign(scene.patches.size(), 0.0);
    }
    void local(const RowRange& rows) override {
        const ComputeOptions o = block_options(job_, visibility_, rows, &cancel_, partly_hidden);
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

    const Job& job_;
    const Scene& scene_;
    const Visibility* visibility_;
    const CancellationFlag& cancel_;
    bool emit_sparse_;
    std::mutex mutex_;
};

// Every rank's rows of a vector to every rank: one non-blocking all-gather per exchange, polled
// with short sleeps (a blocking one spins a core that another rank on the node may need). Each
// rank sends its status and change first, then its rows in the order it keeps them.
class MpiExchange final : public Exchange {
  public:
    explicit MpiExchange(const Owners& owners) : owners_(owners) {}

    Exchanged exchange(Columns& x, RankStatus status, double change) override {
        const Eigen::Index k = x.cols();
        const std::size_t ranks = owners_.size();
        std::vector<int> counts(ranks), displs(ranks);
        std::size_t total = 0;
        for (std::size_t r = 0; r < ranks; ++r) {
            std::size_t rows = 0;
            for (const RowRange& b : owners_[r]) rows += b.size();
            const std::size_t count = 2 + rows * static_cast<std::size_t>(k);
            if (total + count > static_cast<std::size_t>(std::numeric_limits<int>::max()))
                throw ResourceError("distributed: the solution vector is more than MPI's 2 GB");
            counts[r] = static_cast<int>(count);
            displs[r] = static_cast<int>(total);
            total += count;
        }
        send_.clear();
        send_.push_back(double(static_cast<int>(status)));
        send_.push_back(change);
        for (const RowRange& b : owners_[static_cast<std::size_t>(g_rank)])
            for (std::size_t i = b.begin; i < b.end; ++i)
                for (Eigen::Index c = 0; c < k; ++c)
                    send_.push_back(x(static_cast<Eigen::Index>(i), c));
        received_.resize(total);
        MPI_Request request;
        MPI_Iallgatherv(send_.data(), counts[static_cast<std::size_t>(g_rank)], MPI_DOUBLE,
                        received_.data(), counts.data(), displs.data(), MPI_DOUBLE, g_comm,
                        &request);
        complete(request, std::chrono::microseconds(5), std::chrono::microseconds(500));
        Exchanged e;
        for (std::size_t r = 0; r < ranks; ++r) {
            const double* p = received_.data() + displs[r];
            const auto st = static_cast<RankStatus>(static_cast<int>(p[0]));
            if (static_cast<int>(st) > static_cast<int>(e.status)) {
                e.status = st;
                e.rank = static_cast<int>(r);
            }
            e.change = std::max(e.change, p[1]);
            if (static_cast<int>(r) == g_rank) continue;
            p += 2;
            for (const RowRange& b : owners_[r])
                for (std::size_t i = b.begin; i < b.end; ++i)
                    for (Eigen::Index c = 0; c < k; ++c) x(static_cast<Eigen::Index>(i), c) = *p++;
        }
        return e;
    }

  private:
    const Owners& owners_;
    std::vector<double> send_, received_;
};

// A block of kept rows that changes rank.
struct Move {
    RowRange rows;
    std::int32_t from = 0, to = 0;
};

// The moves that even out the work of a product over the ranks: the rows follow the cost of
// computing them, which may differ from a product's (rows, or stored entries) many times over.
// While it helps, the busiest rank gives the least busy one its largest block that lowers the
// larger of the two loads. Deterministic: the same blocks give the same moves.
std::vector<Move> balancing_moves(Owners& owners, const std::map<std::size_t, double>& weights) {
    const std::size_t ranks = owners.size();
    std::vector<double> load(ranks, 0.0);
    for (std::size_t r = 0; r < ranks; ++r)
        for (const RowRange& b : owners[r]) load[r] += weights.at(b.begin);
    std::vector<Move> moves;
    for (std::size_t step = 0; step < weights.size(); ++step) {
        const auto most = std::size_t(std::max_element(load.begin(), load.end()) - load.begin());
        const auto least = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
        const double gap = load[most] - load[least];
        // A block of weight w < gap lowers max(load[most], load[least] + w).
        std::optional<std::size_t> pick;
        double best = 0.0;
        for (std::size_t k = 0; k < owners[most].size(); ++k) {
            const double w = weights.at(owners[most][k].begin);
            if (w < gap && w > best) {
                best = w;
                pick = k;
            }
        }
        if (!pick || best < 0.02 * load[most]) break;
        const RowRange b = owners[most][*pick];
        owners[most].erase(owners[most].begin() + std::ptrdiff_t(*pick));
        owners[least].push_back(b);
        load[most] -= best;
        load[least] += best;
        moves.push_back({b, std::int32_t(most), std::int32_t(least)});
    }
    for (auto& blocks : owners)
        std::sort(blocks.begin(), blocks.end(),
                  [](const RowRange& a, const RowRange& b) { return a.begin < b.begin; });
    return moves;
}

void put_kept_block(WireWriter& w, const KeptBlock& b, std::size_t n) {
    w.put(b.rows);
    if (kept_rows().sparse) {
        w.put_vector(b.indptr);
        w.put_vector(b.indices);
        w.put_vector(b.values);
    } else {
        w.put_array(b.row(b.rows.begin, n), b.rows.size() * n);
    }
}

KeptBlock get_kept_block(WireReader& r, std::size_t n) {
    const auto rows = r.get<RowRange>();
    if (!kept_rows().sparse) {
        const char* data = nullptr;
        if (r.get_array<double>(&data) != rows.size() * n)
            throw Error("distributed: a block of the wrong size");
        // Copied into place at the alignment the rows have in the whole matrix.
        std::vector<double> values(rows.size() * n);
        if (!values.empty()) std::memcpy(values.data(), data, values.size() * sizeof(double));
        return keep_dense(rows, values.data(), n);
    }
    KeptBlock b;
    b.rows = rows;
    b.indptr = r.get_vector<std::int64_t>();
    b.indices = r.get_vector<std::int32_t>();
    b.values = r.get_vector<double>();
    return b;
}

// Every rank's part of the moves: sends the blocks it gives (non-blocking), receives the ones
// it gets, in the order of the moves (MPI keeps the order of one sender's messages). Returns
// the failure of this rank, or empty.
std::string make_moves(const std::vector<Move>& moves) {
    KeptRows& kept = kept_rows();
    try {
        std::vector<std::vector<char>> sent;
        std::vector<MPI_Request> requests;
        sent.reserve(moves.size());
        for (const Move& m : moves) {
            if (m.from != g_rank) continue;
            const auto it =
                std::find_if(kept.blocks.begin(), kept.blocks.end(),
                             [&](const KeptBlock& b) { return b.rows.begin == m.rows.begin; });
            if (it == kept.blocks.end()) throw Error("distributed: a block to move is not here");
            WireWriter w;
            put_kept_block(w, *it, kept.n);
            sent.push_back(std::move(w.bytes()));
            kept.blocks.erase(it);
            requests.emplace_back();
            MPI_Isend(sent.back().data(), message_size(sent.back()), MPI_BYTE, m.to, kTagMove,
                      g_comm, &requests.back());
        }
        for (const Move& m : moves) {
            if (m.to != g_rank) continue;
            const std::vector<char> bytes = receive_bytes(wait_for(m.from, kTagMove, nullptr));
            WireReader r(bytes.data(), bytes.size());
            kept.blocks.push_back(get_kept_block(r, kept.n));
        }
        for (MPI_Request& q : requests)
            complete(q, std::chrono::microseconds(20), std::chrono::microseconds(1000));
        std::sort(
            kept.blocks.begin(), kept.blocks.end(),
            [](const KeptBlock& a, const KeptBlock& b) { return a.rows.begin < b.rows.begin; });
        return {};
    } catch (const std::bad_alloc&) {
        return kOutOfMemory;
    } catch (const std::exception& e) {
        return e.what();
    }
}

std::vector<char> moves_bytes(const std::vector<Move>& moves) {
    WireWriter w;
    w.put_vector(moves);
    return std::move(w.bytes());
}

// After the moves every rank says whether its own went well (a gather to rank 0; a failed
// rank sends its message first).
std::vector<std::int32_t> gather_move_status(const std::string& failure) {
    if (!failure.empty() && g_rank != 0) {
        WireWriter w;
        w.put(Status::failed);
        w.put_string(failure);
        send_bytes(w.bytes(), 0, kTagResult);
    }
    std::int32_t mine = failure.empty() ? 0 : 1;
    std::vector<std::int32_t> all(static_cast<std::size_t>(g_rank == 0 ? g_size : 0));
    MPI_Gather(&mine, 1, MPI_INT32_T, all.data(), 1, MPI_INT32_T, 0, g_comm);
    return all;
}

void work_on_moves(const std::vector<char>& bytes) {
    std::string failure;
    std::vector<Move> moves;
    try {
        WireReader r(bytes.data(), bytes.size());
        moves = r.get_vector<Move>();
    } catch (const std::exception& e) {
        failure = e.what();
    }
    if (failure.empty()) failure = make_moves(moves);
    gather_move_status(failure);
}

// Rank 0, after the ranks gathered their status (gather_move_status()): the first failure, its
// own or a rank's, thrown as that rank's.
void throw_move_failures(const std::string& failure, const std::vector<std::int32_t>& status) {
    if (!failure.empty()) throw Error(failure);
    for (int r = 1; r < g_size; ++r)
        if (status[static_cast<std::size_t>(r)] != 0) {
            const std::vector<char> bytes = receive_bytes(wait_for(r, kTagResult, nullptr));
            WireReader reader(bytes.data(), bytes.size());
            reader.get<Status>();
            throw Error(fmt::format("rank {}: {}", r, reader.get_string()));
        }
}

// The header of distribute_rows()'s blocks: which rows, whose, and the id they are kept under.
std::vector<char> scatter_bytes(std::uint64_t id, bool sparse, std::size_t n,
                                const Owners& owners) {
    WireWriter w;
    w.put(id);
    w.put<std::uint8_t>(sparse);
    w.put<std::uint64_t>(n);
    w.put<std::uint64_t>(owners.size());
    for (const auto& blocks : owners) w.put_vector(blocks);
    return std::move(w.bytes());
}

// A worker's part of distribute_rows(): its block from rank 0 (a flag first: rank 0 that failed
// on the way sends no block), then its status.
void work_on_scatter(const std::vector<char>& bytes) {
    WireReader r(bytes.data(), bytes.size());
    const auto id = r.get<std::uint64_t>();
    const bool sparse = r.get<std::uint8_t>() != 0;
    const auto n = r.get<std::uint64_t>();
    Owners owners(r.get<std::uint64_t>());
    for (auto& blocks : owners) blocks = r.get_vector<RowRange>();
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    kept.sparse = sparse;
    kept.n = n;
    kept_id() = id;
    std::string failure;
    if (!owners.at(static_cast<std::size_t>(g_rank)).empty()) {
        try {
            const std::vector<char> got = receive_bytes(wait_for(0, kTagMove, nullptr));
            WireReader block(got.data(), got.size());
            if (block.get<std::uint8_t>() != 0) kept.blocks.push_back(get_kept_block(block, n));
        } catch (const std::bad_alloc&) {
            failure = kOutOfMemory;
        } catch (const std::exception& e) {
            failure = e.what();
        }
    }
    gather_move_status(failure);
}

// Rank 0: distribute_rows() over the ranks. The blocks go one at a time, so that rank 0 holds
// at most its own block and one other besides F.
DistributedRows scatter_rows(const WholeRows& whole) {
    if (g_size <= 1 || g_rank != 0) return distribute_rows_here(whole);
    DistributedRows out = whole.head;
    const std::size_t n = out.n;
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    kept.sparse = out.sparse;
    kept.n = n;
    const std::uint64_t id = ++kept_id();
    Owners owners(static_cast<std::size_t>(g_size));
    out.rows_per_rank.assign(owners.size(), 0.0);
    for (std::size_t r = 0; r < whole.blocks.size() && r < owners.size(); ++r)
        if (whole.blocks[r].size() > 0) {
            owners[r].push_back(whole.blocks[r]);
            out.rows_per_rank[r] = double(whole.blocks[r].size());
        }
    broadcast_command(kCommandScatter, scatter_bytes(id, out.sparse, n, owners));
    out.row_sums.assign(n, 0.0);
    std::string failure;
    for (std::size_t r = 0; r < owners.size(); ++r) {
        if (owners[r].empty()) continue;
        WireWriter w;
        try {
            if (!failure.empty()) throw Error(failure);
            KeptBlock b = whole.block(owners[r].front());
            const std::vector<double> sums = kept_row_sums(b, n, out.sparse);
            std::copy(sums.begin(), sums.end(),
                      out.row_sums.begin() + std::ptrdiff_t(b.rows.begin));
            if (r == 0) {
                kept.blocks.push_back(std::move(b));
                continue;
            }
            w.put<std::uint8_t>(1);
            put_kept_block(w, b, n);
        } catch (const std::bad_alloc&) {
            if (failure.empty()) failure = kOutOfMemory;
        } catch (const std::exception& e) {
            if (failure.empty()) failure = e.what();
        }
        if (r == 0) continue;
        if (!failure.empty()) {
            w = WireWriter{};
            w.put<std::uint8_t>(0);
        }
        send_bytes(w.bytes(), int(r), kTagMove);
    }
    throw_move_failures(failure, gather_move_status(failure));
    g_owners = std::move(owners);
    out.id = id;
    return out;
}

// What every rank needs for a solve of kept rows.
struct SolveJob {
    std::uint64_t kept = 0;
    Owners owners;
    Columns d, c;
    SolverKind solver = SolverKind::gauss_seidel;
    double residual = 0.0;
    long long max_iterations = 0;
    int threads = 0;
    bool fail_if_not_converged = true;

    /// The job of a solve of kept rows or operator `kept` (owners left empty).
    static SolveJob of(std::uint64_t kept, const Columns& d, const Columns& c,
                       const SolverOptions& options) {
        SolveJob job;
        job.kept = kept;
        job.d = d;
        job.c = c;
        job.solver = options.solver;
        job.residual = options.residual;
        job.max_iterations = options.max_iterations;
        job.threads = options.threads;
        job.fail_if_not_converged = options.fail_if_not_converged;
        return job;
    }

    SolverOptions options() const {
        SolverOptions o;
        o.solver = solver;
        o.residual = residual;
        o.max_iterations = max_iterations;
        o.threads = threads;
        o.fail_if_not_converged = fail_if_not_converged;
        return o;
    }
};

std::vector<char> solve_job_bytes(const SolveJob& job) {
    WireWriter w;
    w.put(job.kept);
    w.put<std::uint64_t>(job.owners.size());
    for (const auto& blocks : job.owners) w.put_vector(blocks);
    w.put<std::int64_t>(job.d.rows());
    w.put<std::int64_t>(job.d.cols());
    w.put_array(job.d.data(), static_cast<std::size_t>(job.d.size()));
    w.put_array(job.c.data(), static_cast<std::size_t>(job.c.size()));
    w.put(job.solver);
    w.put(job.residual);
    w.put(job.max_iterations);
    w.put(job.threads);
    w.put<std::uint8_t>(job.fail_if_not_converged);
    return std::move(w.bytes());
}

SolveJob get_solve_job(const std::vector<char>& bytes) {
    WireReader r(bytes.data(), bytes.size());
    SolveJob job;
    job.kept = r.get<std::uint64_t>();
    job.owners.resize(r.get<std::uint64_t>());
    for (auto& blocks : job.owners) blocks = r.get_vector<RowRange>();
    const auto rows = r.get<std::int64_t>(), cols = r.get<std::int64_t>();
    job.d.resize(rows, cols);
    job.c.resize(rows, cols);
    for (Columns* m : {&job.d, &job.c}) {
        const std::vector<double> v = r.get_vector<double>();
        if (v.size() != static_cast<std::size_t>(m->size()))
            throw Error("distributed: a system of the wrong size");
        std::copy(v.begin(), v.end(), m->data());
    }
    job.solver = r.get<SolverKind>();
    job.residual = r.get<double>();
    job.max_iterations = r.get<long long>();
    job.threads = r.get<int>();
    job.fail_if_not_converged = r.get<std::uint8_t>() != 0;
    return job;
}

// A worker's answer when a solve stopped: only a rank whose own failure stopped it tells rank 0
// why.
void tell_own_failure(const RankStopped& e) {
    if (e.state.rank != g_rank || e.state.status != RankStatus::failed) return;
    WireWriter w;
    w.put(Status::failed);
    w.put_string(e.own_message);
    send_bytes(w.bytes(), 0, kTagResult);
}

// A worker's part of a solve: the same iteration as rank 0's on its own rows. It ends with the
// solve on every rank; only a rank whose own failure stopped it tells rank 0 why.
void work_on_solve(const std::vector<char>& bytes) {
    const SolveJob job = get_solve_job(bytes);
    MpiExchange exchange(job.owners);
    Columns x, fx;
    try {
        if (job.kept != kept_id()) throw Error("distributed: the rows of F are not the ones kept");
        solve_kept(kept_rows(), g_rank, exchange, job.d, job.c, job.options(), x, fx);
    } catch (const RankStopped& e) {
        tell_own_failure(e);
    } catch (const std::exception&) {
        // Not converged (and any error of the options): rank 0 meets the same and reports it.
    }
}

// ---- The hierarchical operator spread over the ranks (hierarchical_solve.h) ----

// Whether every rank did its step well: an all-gather of each rank's status (0 fine, 1
// interrupted, 2 failed). Rank 0 throws the first rank's failure (its message sent by that
// rank), Cancelled for an interruption; the other ranks return false. Every rank calls it at
// the same steps.
bool agree(const std::string& failure, bool cancelled) {
    const std::int32_t mine = cancelled ? 1 : failure.empty() ? 0 : 2;
    std::vector<std::int32_t> all(static_cast<std::size_t>(g_size));
    MPI_Request request;
    MPI_Iallgather(&mine, 1, MPI_INT32_T, all.data(), 1, MPI_INT32_T, g_comm, &request);
    complete(request, std::chrono::microseconds(20), std::chrono::microseconds(1000));
    int first = -1;
    for (int r = 0; r < g_size && first < 0; ++r)
        if (all[static_cast<std::size_t>(r)] != 0) first = r;
    if (first < 0) return true;
    const std::int32_t what = all[static_cast<std::size_t>(first)];
    if (g_rank == first && first != 0 && what == 2) {
        WireWriter w;
        w.put(Status::failed);
        w.put_string(failure);
        send_bytes(w.bytes(), 0, kTagResult);
    }
    if (g_rank != 0) return false;
    if (what == 1) {
        if (first == 0) throw Cancelled();
        throw Cancelled(fmt::format("rank {}: interrupted", first));
    }
    if (first == 0) throw Error(failure);
    const std::vector<char> bytes = receive_bytes(wait_for(first, kTagResult, nullptr));
    WireReader reader(bytes.data(), bytes.size());
    reader.get<Status>();
    throw Error(fmt::format("rank {}: {}", first, reader.get_string()));
}

// Runs `step`, keeping its failure (or interruption) for agree().
template <class Step>
void guarded_step(const Step& step, std::string& failure, bool& cancelled) {
    try {
        step();
    } catch (const Cancelled&) {
        cancelled = true;
    } catch (const std::bad_alloc&) {
        failure = kOutOfMemory;
    } catch (const std::exception& e) {
        failure = e.what();
    }
}

// The running sums of a product handed from rank to rank (ChunkChain): [status, first rank
// with it, Yt, Zt], then the last rank's [status, rank, Y] to every rank. Non-blocking and
// polled with short sleeps, as the other exchanges.
class MpiChain final : public ChunkChain {
  public:
    Exchanged product(const HierarchicalFormFactors* part,
                      const HierarchicalFormFactors::Partials& own, Eigen::Index n, Eigen::Index k,
                      RankStatus status, Columns& Y) override {
        const auto nk = static_cast<std::size_t>(n * k);
        if (2 + 2 * nk > static_cast<std::size_t>(std::numeric_limits<int>::max()))
            throw ResourceError("distributed: the solution vector is more than MPI's 2 GB");
        sums_.assign(2 + 2 * nk, 0.0);
        if (g_rank > 0) {
            wait_for(g_rank - 1, kTagChain, nullptr);
            MPI_Recv(sums_.data(), static_cast<int>(sums_.size()), MPI_DOUBLE, g_rank - 1,
                     kTagChain, g_comm, MPI_STATUS_IGNORE);
        }
        auto worst = static_cast<RankStatus>(static_cast<int>(sums_[0]));
        int first = static_cast<int>(sums_[1]);
        if (static_cast<int>(status) > static_cast<int>(worst)) {
            worst = status;
            first = g_rank;
        }
        // Added in place: elementwise sums, the same bits as one process's.
        Eigen::Map<Columns> Yt(sums_.data() + 2, n, k), Zt(sums_.data() + 2 + nk, n, k);
        if (worst == RankStatus::fine)
            for (std::size_t c = 0; c < own.y.size(); ++c) {
                Yt += own.y[c];
                Zt += own.z[c];
            }
        sums_[0] = double(static_cast<int>(worst));
        sums_[1] = double(first);
        const int last = g_size - 1;
        if (g_rank < last) {
            MPI_Request request;
            MPI_Isend(sums_.data(), static_cast<int>(sums_.size()), MPI_DOUBLE, g_rank + 1,
                      kTagChain, g_comm, &request);
            complete(request, std::chrono::microseconds(5), std::chrono::microseconds(500));
        }
        result_.assign(2 + nk, 0.0);
        if (g_rank == last) {
            result_[0] = sums_[0];
            result_[1] = sums_[1];
            if (worst == RankStatus::fine) {
                if (!part) throw Error("distributed: the last rank holds no operator");
                part->finish_product(Yt, Zt, Y);
                std::copy(Y.data(), Y.data() + nk, result_.begin() + 2);
            }
        }
        MPI_Request request;
        MPI_Ibcast(result_.data(), static_cast<int>(result_.size()), MPI_DOUBLE, last, g_comm,
                   &request);
        complete(request, std::chrono::microseconds(5), std::chrono::microseconds(500));
        Exchanged e;
        e.status = static_cast<RankStatus>(static_cast<int>(result_[0]));
        e.rank = static_cast<int>(result_[1]);
        if (e.status == RankStatus::fine && g_rank != last) {
            Y.resize(n, k);
            std::copy(result_.begin() + 2, result_.end(), Y.data());
        }
        return e;
    }

  private:
    std::vector<double> sums_, result_;
};

void put_hierarchical_block(WireWriter& w, const HierarchicalFormFactors::Block& b) {
    w.put(b.p);
    w.put(b.m);
    w.put(b.q);
    w.put(b.n);
    w.put(b.rank);
    w.put_vector(b.u);
    w.put_vector(b.v);
}

HierarchicalFormFactors::Block get_hierarchical_block(WireReader& r) {
    HierarchicalFormFactors::Block b;
    b.p = r.get<std::uint32_t>();
    b.m = r.get<std::uint32_t>();
    b.q = r.get<std::uint32_t>();
    b.n = r.get<std::uint32_t>();
    b.rank = r.get<std::uint32_t>();
    b.u = r.get_vector<double>();
    b.v = r.get_vector<double>();
    return b;
}

std::vector<char> hierarchical_job_bytes(std::uint64_t id, const HierarchicalOptions& o,
                                         const Scene& scene) {
    WireWriter w;
    w.put(id);
    w.put(o.tolerance);
    w.put(o.eta);
    w.put<std::uint64_t>(o.leaf_size);
    w.put(o.threads);
    put_scene(w, scene);
    return std::move(w.bytes());
}

// Contiguous runs of chunks, one per rank, each with about 1/ranks of the product's work:
// where each rank's run starts, and the end.
std::vector<std::size_t> chunk_runs(const std::vector<double>& chunk_work, int ranks) {
    double total = 0.0;
    for (double w : chunk_work) total += w;
    std::vector<std::size_t> first{0};
    double acc = 0.0;
    std::size_t c = 0;
    for (int r = 1; r < ranks; ++r) {
        const double target = total * double(r) / double(ranks);
        // Up to the chunk whose end is nearer the target than its start.
        while (c < chunk_work.size() && acc + 0.5 * chunk_work[c] < target) acc += chunk_work[c++];
        first.push_back(c);
    }
    first.push_back(chunk_work.size());
    return first;
}

// Every rank's part of build_hierarchical(): the plan, its share of the blocks, the blocks to
// the ranks that hold their chunks, and the row sums. Returns the operator as rank 0 knows it
// (rank 0 throws the first failure of any rank; the others return an empty one).
DistributedHierarchical build_on_ranks(const Scene& scene, const HierarchicalOptions& options,
                                       std::uint64_t id) {
    using Block = HierarchicalFormFactors::Block;
    Stopwatch wall;
    kept_operator().reset();
    kept_operator_id() = id;
    DistributedHierarchical out;
    std::string failure;
    bool cancelled = false;
    std::optional<HierarchicalPlan> plan;
    double partition = 0.0;
    guarded_step(
        [&] {
            if (const char* fail = std::getenv("FORMFACTOR_TEST_FAIL_RANK");
                fail && std::atoi(fail) == g_rank)
                throw Error(fmt::format("a failure injected on rank {} (FORMFACTOR_TEST_FAIL_RANK)",
                                        g_rank));
            Stopwatch sw;
            plan.emplace(scene, options);
            partition = sw.seconds();
        },
        failure, cancelled);
    if (!agree(failure, cancelled)) return out;

    // Who computes which block: the largest estimated cost first, each to the rank with the
    // least so far (the same on every rank).
    const std::size_t count = plan->blocks();
    const auto ranks = static_cast<std::size_t>(g_size);
    std::vector<std::size_t> by_cost(count);
    std::iota(by_cost.begin(), by_cost.end(), 0);
    std::vector<double> cost(count);
    for (std::size_t k = 0; k < count; ++k) cost[k] = plan->estimated_cost(k);
    std::stable_sort(by_cost.begin(), by_cost.end(),
                     [&](std::size_t a, std::size_t b) { return cost[a] > cost[b]; });
    std::vector<std::int32_t> builder(count);
    std::vector<double> load(ranks, 0.0);
    for (std::size_t k : by_cost) {
        const auto r = std::size_t(std::min_element(load.begin(), load.end()) - load.begin());
        builder[k] = std::int32_t(r);
        load[r] += cost[k];
    }
    std::vector<std::vector<std::size_t>> built_by(ranks);
    for (std::size_t k = 0; k < count; ++k)
        built_by[static_cast<std::size_t>(builder[k])].push_back(k);
    const std::vector<std::size_t>& mine = built_by[static_cast<std::size_t>(g_rank)];

    HierarchicalStats counts;
    std::vector<Block> built;
    double busy = 0.0;
    guarded_step(
        [&] {
            Stopwatch sw;
            built = plan->compute(mine, counts);
            busy = sw.seconds();
        },
        failure, cancelled);
    if (!agree(failure, cancelled)) return out;

    // Every rank's times and counts, and every block's rank, values and work: one all-gather.
    std::vector<int> sizes(ranks), displs(ranks);
    std::size_t total = 0;
    for (std::size_t r = 0; r < ranks; ++r) {
        sizes[r] = static_cast<int>(4 + 3 * built_by[r].size());
        displs[r] = static_cast<int>(total);
        total += static_cast<std::size_t>(sizes[r]);
    }
    std::vector<double> mine_sent{partition, busy, double(counts.entries_computed),
                                  double(counts.low_rank_fallbacks)};
    for (const Block& b : built) {
        mine_sent.push_back(double(b.rank));
        mine_sent.push_back(double(b.u.size() + b.v.size()));
        mine_sent.push_back(HierarchicalFormFactors::block_work(b));
    }
    std::vector<double> got(total);
    {
        MPI_Request request;
        MPI_Iallgatherv(mine_sent.data(), sizes[static_cast<std::size_t>(g_rank)], MPI_DOUBLE,
                        got.data(), sizes.data(), displs.data(), MPI_DOUBLE, g_comm, &request);
        complete(request, std::chrono::microseconds(20), std::chrono::microseconds(1000));
    }
    HierarchicalStats st = plan->stats();
    std::vector<std::uint32_t> block_rank(count);
    std::vector<std::size_t> block_values(count);
    std::vector<double> work(count);
    out.partition_seconds.assign(ranks, 0.0);
    out.build_seconds.assign(ranks, 0.0);
    out.blocks_built.assign(ranks, 0.0);
    for (std::size_t r = 0; r < ranks; ++r) {
        const double* p = got.data() + displs[r];
        out.partition_seconds[r] = p[0];
        out.build_seconds[r] = p[1];
        out.blocks_built[r] = double(built_by[r].size());
        st.entries_computed += static_cast<std::size_t>(p[2]);
        st.low_rank_fallbacks += static_cast<std::size_t>(p[3]);
        p += 4;
        for (std::size_t k : built_by[r]) {
            block_rank[k] = static_cast<std::uint32_t>(p[0]);
            block_values[k] = static_cast<std::size_t>(p[1]);
            work[k] = p[2];
            p += 3;
        }
    }
    count_block_values(block_rank, block_values, st);

    // The operator's chunks (as one process makes them), in runs of about equal work.
    const std::vector<std::size_t> bounds = HierarchicalFormFactors::chunk_bounds(work);
    const std::size_t chunks = bounds.size() - 1;
    std::vector<double> chunk_work(chunks, 0.0);
    for (std::size_t c = 0; c < chunks; ++c)
        for (std::size_t k = bounds[c]; k < bounds[c + 1]; ++k) chunk_work[c] += work[k];
    const std::vector<std::size_t> run = chunk_runs(chunk_work, g_size);
    std::vector<std::int32_t> holder(count);
    out.blocks_held.assign(ranks, 0.0);
    out.chunks_held.assign(ranks, 0.0);
    out.product_work.assign(ranks, 0.0);
    for (std::size_t r = 0; r < ranks; ++r) {
        out.chunks_held[r] = double(run[r + 1] - run[r]);
        for (std::size_t k = bounds[run[r]]; k < bounds[run[r + 1]]; ++k) {
            holder[k] = std::int32_t(r);
            out.blocks_held[r] += 1.0;
            out.product_work[r] += work[k];
        }
    }
    for (std::size_t k = 0; k < count; ++k)
        if (holder[k] != builder[k]) out.moved_bytes += 8.0 * double(block_values[k]);

    // The blocks to their holders: messages of up to kMoveBytes from each builder to each
    // holder it serves, the blocks in index order (every rank knows who sends what).
    const std::size_t first_block = bounds[run[static_cast<std::size_t>(g_rank)]];
    const std::size_t end_block = bounds[run[static_cast<std::size_t>(g_rank) + 1]];
    std::vector<Block> held(end_block - first_block);
    guarded_step(
        [&] {
            constexpr std::size_t kMoveBytes = std::size_t{256} << 20;
            std::vector<std::vector<char>> sent;
            std::vector<MPI_Request> requests;
            // (A buffer keeps its address when `sent` grows: its vector is moved, not copied.)
            auto send = [&](WireWriter& w, int to) {
                sent.push_back(std::move(w.bytes()));
                w = WireWriter{};
                requests.emplace_back();
                MPI_Isend(sent.back().data(), message_size(sent.back()), MPI_BYTE, to, kTagMove,
                          g_comm, &requests.back());
            };
            for (std::size_t to = 0; to < ranks; ++to) {
                WireWriter w;
                for (std::size_t i = 0; i < mine.size(); ++i) {
                    if (static_cast<std::size_t>(holder[mine[i]]) != to) continue;
                    if (int(to) == g_rank) {
                        held[mine[i] - first_block] = std::move(built[i]);
                        continue;
                    }
                    put_hierarchical_block(w, built[i]);
                    built[i] = Block{};
                    if (w.bytes().size() >= kMoveBytes) send(w, int(to));
                }
                if (!w.bytes().empty()) send(w, int(to));
            }
            built.clear();
            for (std::size_t from = 0; from < ranks; ++from) {
                if (int(from) == g_rank) continue;
                std::vector<std::size_t> theirs;
                for (std::size_t k : built_by[from])
                    if (holder[k] == g_rank) theirs.push_back(k);
                for (std::size_t got_blocks = 0; got_blocks < theirs.size();) {
                    const std::vector<char> bytes =
                        receive_bytes(wait_for(int(from), kTagMove, nullptr));
                    WireReader r(bytes.data(), bytes.size());
                    while (!r.at_end() && got_blocks < theirs.size())
                        held[theirs[got_blocks++] - first_block] = get_hierarchical_block(r);
                }
            }
            for (MPI_Request& q : requests)
                complete(q, std::chrono::microseconds(20), std::chrono::microseconds(1000));
            std::vector<std::size_t> local(run[static_cast<std::size_t>(g_rank) + 1] -
                                           run[static_cast<std::size_t>(g_rank)] + 1);
            for (std::size_t c = 0; c < local.size(); ++c)
                local[c] = bounds[run[static_cast<std::size_t>(g_rank)] + c] - first_block;
            HierarchicalStats whole = st;
            kept_operator() =
                std::make_unique<HierarchicalFormFactors>(HierarchicalFormFactors::part(
                    plan->areas(), plan->order(), std::move(held), std::move(local),
                    run[static_cast<std::size_t>(g_rank)], whole));
        },
        failure, cancelled);
    if (!agree(failure, cancelled)) {
        kept_operator().reset();
        return out;
    }
    // The whole operator's bytes, as one process counts them.
    st.bytes = 8 * (st.dense_values + st.low_rank_values) + count * sizeof(Block) +
               scene.patches.size() * (2 * sizeof(double) + sizeof(std::uint32_t));

    // The row sums: a product with ones over the chain.
    const auto n = static_cast<Eigen::Index>(scene.patches.size());
    MpiChain chain;
    const HierarchicalFormFactors* part = kept_operator().get();
    HierarchicalFormFactors::Partials own;
    failure.clear();
    guarded_step([&] { own = part->partial_products(Columns::Ones(n, 1), options.threads); },
                 failure, cancelled);
    Columns sums;
    const Exchanged e = chain.product(part, own, n, 1,
                                      cancelled         ? RankStatus::cancelled
                                      : failure.empty() ? RankStatus::fine
                                                        : RankStatus::failed,
                                      sums);
    (void)e;  // the chain told every rank; agree() tells rank 0 which rank and why
    if (!agree(failure, cancelled)) return out;
    st.seconds = wall.seconds();
    out.n = scene.patches.size();
    out.areas = plan->areas();
    out.row_sums.assign(sums.data(), sums.data() + n);
    out.stats = st;
    out.id = id;
    return out;
}

void work_on_hierarchical(const std::vector<char>& bytes) {
    std::uint64_t id = 0;
    HierarchicalOptions o;
    Scene scene;
    std::string failure;
    try {
        WireReader r(bytes.data(), bytes.size());
        id = r.get<std::uint64_t>();
        o.tolerance = r.get<double>();
        o.eta = r.get<double>();
        o.leaf_size = r.get<std::uint64_t>();
        o.threads = r.get<int>();
        scene = get_scene(r);
    } catch (const std::exception& e) {
        failure = e.what();
    }
    if (!failure.empty()) {
        agree(failure, false);
        return;
    }
    build_on_ranks(scene, o, id);
}

// A worker's part of a solve on the operator, as work_on_solve() for kept rows.
void work_on_operator_solve(const std::vector<char>& bytes) {
    const SolveJob job = get_solve_job(bytes);
    MpiChain chain;
    Columns x, fx;
    try {
        const HierarchicalFormFactors* part =
            job.kept == kept_operator_id() ? kept_operator().get() : nullptr;
        solve_operator_kept(part, g_rank, chain, job.d.rows(), job.d, job.c, job.options(), x, fx);
    } catch (const RankStopped& e) {
        tell_own_failure(e);
    } catch (const std::exception&) {
        // Not converged (and any error of the options): rank 0 meets the same and reports it.
    }
}

// Rank 0's ray tracer for its own blocks.
std::unique_ptr<Visibility> rank0_visibility(const Method& method, const Scene& scene,
                                             const ComputeOptions& options, StepTimes& timings) {
    if (options.prebuilt_visibility || !method.needs_visibility() || scene.patches.empty())
        return nullptr;
    Stopwatch sw;
    auto v = make_visibility(scene, options.visibility);
    timings.add("visibility", sw.lap());
    return v;
}

}  // namespace

bool built_with_mpi() { return true; }

Session::Session(int& argc, char**& argv) {
    if (g_active || !launched_by_mpi()) return;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &g_thread_level);
    g_comm = MPI_COMM_WORLD;
    MPI_Comm_rank(g_comm, &g_rank);
    MPI_Comm_size(g_comm, &g_size);
    g_active = true;
}

Session::~Session() {
    if (!g_active) return;
    finish();
    MPI_Finalize();
    g_active = false;
}

struct Communicator::Saved {
    bool active, finished;
    int rank, size, thread_level;
    MPI_Comm comm;
};

Communicator::Communicator(std::int64_t fortran_handle) {
    int initialised = 0, finalised = 0;
    MPI_Initialized(&initialised);
    MPI_Finalized(&finalised);
    if (!initialised || finalised)
        throw Error("comm: MPI is not initialised in this process (import mpi4py.MPI first)");
    const MPI_Comm comm = MPI_Comm_f2c(static_cast<MPI_Fint>(fortran_handle));
    if (comm == MPI_COMM_NULL) throw OptionError("comm", "is MPI.COMM_NULL");
    saved_ = std::make_unique<Saved>(
        Saved{g_active, g_finished, g_rank, g_size, g_thread_level, g_comm});
    g_comm = comm;
    MPI_Comm_rank(g_comm, &g_rank);
    MPI_Comm_size(g_comm, &g_size);
    MPI_Query_thread(&g_thread_level);
    g_active = true;
    g_finished = false;
}

Communicator::~Communicator() {
    finish();
    g_active = saved_->active;
    g_finished = saved_->finished;
    g_rank = saved_->rank;
    g_size = saved_->size;
    g_thread_level = saved_->thread_level;
    g_comm = saved_->comm;
}

int Session::rank() const { return g_rank; }
int Session::size() const { return g_size; }
int rank() { return g_rank; }
int size() { return g_size; }

int serve() {
    if (!g_active || g_rank == 0) return 0;
    for (;;) {
        wait_for(0, kTagCommand, &current_cancellation());
        std::int64_t command = 0;
        MPI_Recv(&command, 1, MPI_INT64_T, 0, kTagCommand, g_comm, MPI_STATUS_IGNORE);
        if (command == kCommandJob)
            work_on_job(receive_job());
        else if (command == kCommandSolve)
            work_on_solve(receive_job());
        else if (command == kCommandMove)
            work_on_moves(receive_job());
        else if (command == kCommandScatter)
            work_on_scatter(receive_job());
        else if (command == kCommandOperator)
            work_on_hierarchical(receive_job());
        else if (command == kCommandOperatorSolve)
            work_on_operator_solve(receive_job());
        else
            return 0;
    }
}

void finish() {
    if (!g_active || g_rank != 0 || g_finished) return;
    g_finished = true;
    for (int r = 1; r < g_size; ++r)
        MPI_Send(&kCommandFinish, 1, MPI_INT64_T, r, kTagCommand, g_comm);
}

const RankShares& last_rank_shares() { return g_shares; }

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

    auto visibility = rank0_visibility(*method, scene, options, result.timings);
    // Stops rank 0's own blocks when another rank fails or the process is interrupted.
    CancellationFlag cancel;
    DenseSink sink(job, scene,
                   options.prebuilt_visibility ? options.prebuilt_visibility : visibility.get(),
                   cancel, result.traits.standard_errors);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    result.timings.add("compute", sw.lap());
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
    const bool strip = job.method == MethodKind::analytic || job.method == MethodKind::mc_target;
    std::size_t max_rows =
        emit_sparse ? 8192
                    : rows_for_budget(double(n) * 8.0 *
                                      ((traits.standard_errors ? 2 : 1) + (strip ? 1 : 0)));
    if (sparse.block_rows > 0) max_rows = std::min(max_rows, sparse.block_rows);

    StepTimes timings;
    auto visibility = rank0_visibility(*method, scene, options, timings);
    CancellationFlag cancel;
    SparseSink sink(job, scene,
                    options.prebuilt_visibility ? options.prebuilt_visibility : visibility.get(),
                    cancel, emit_sparse);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    timings.add("compute", sw.lap());
    const bool standard_errors =
        !sink.blocks.empty() && sink.blocks.begin()->second.has_standard_errors();
    SparseBuilder builder(n, sink.areas.size() == n ? sink.areas : std::vector<double>(n, 0.0),
                          sparse.threshold, standard_errors);
    for (auto& [first, rows] : sink.blocks) {
        builder.append(rows, options.method_options.threads);
        rows = SparseRows{};
    }
    SparseFormFactors F = builder.finish();
    timings.add("threshold", sw.lap());
    SparseComputeResult result =
        sparse_form_factors_from_matrix(scene, std::move(F), options.repair, "distributed");
    for (const auto& [step, seconds] : result.timings.steps) timings.add(step, seconds);
    result.timings = timings;
    result.report = sink.report.take();
    add_shares(result.report);
    result.traits = traits;
    result.run.blocks = g_shares.blocks;
    result.run.block_rows = max_rows;
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
    auto visibility = rank0_visibility(*method, scene, options, out.timings);
    CancellationFlag cancel;
    KeptSink sink(job, scene,
                  options.prebuilt_visibility ? options.prebuilt_visibility : visibility.get(),
                  cancel, emit_sparse);
    Stopwatch sw;
    run_job(job, scene, max_rows, sink, cancel, options.progress);
    out.timings.add("compute", sw.lap());
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

DistributedRows distribute_rows(const FormFactors& F) {
    return scatter_rows(whole_rows(F, g_rank == 0 ? g_size : 1));
}

DistributedRows distribute_rows(const SparseFormFactors& F) {
    return scatter_rows(whole_rows(F, g_rank == 0 ? g_size : 1));
}

// Rank 0 when a solve stopped: Cancelled for an interruption, else the failing rank's message
// (its own, or the one that rank sent).
[[noreturn]] void throw_stopped(const RankStopped& e) {
    const int from = e.state.rank;
    if (e.state.status == RankStatus::cancelled) {
        if (from == 0) throw Cancelled();
        throw Cancelled(fmt::format("rank {}: interrupted", from));
    }
    if (from == 0) throw Error(e.own_message);
    const MPI_Status probed = wait_for(from, kTagResult, nullptr);
    const std::vector<char> bytes = receive_bytes(probed);
    WireReader r(bytes.data(), bytes.size());
    r.get<Status>();
    throw Error(fmt::format("rank {}: {}", from, r.get_string()));
}

SolverStats solve_rows(const DistributedRows& rows, const Columns& d, const Columns& c,
                       const SolverOptions& options, Columns& x, Columns& fx) {
    if (g_size <= 1 || g_rank != 0) return solve_rows_here(rows, d, c, options, x, fx);
    check_kept(rows);
    SolveJob job = SolveJob::of(rows.id, d, c, options);
    job.owners = g_owners;
    broadcast_command(kCommandSolve, solve_job_bytes(job));
    MpiExchange exchange(g_owners);
    try {
        return solve_kept(kept_rows(), 0, exchange, d, c, options, x, fx);
    } catch (const RankStopped& e) {
        throw_stopped(e);
    }
}

DistributedHierarchical build_hierarchical(const Scene& scene, const HierarchicalOptions& options) {
    if (g_size <= 1 || g_rank != 0) return build_operator_here(scene, options);
    const CancellationScope scope(process_cancellation());
    const std::uint64_t id = ++kept_operator_id();
    broadcast_command(kCommandOperator, hierarchical_job_bytes(id, options, scene));
    return build_on_ranks(scene, options, id);
}

SolverStats solve_operator(const DistributedHierarchical& op, const Columns& d, const Columns& c,
                           const SolverOptions& options, Columns& x, Columns& fx) {
    if (g_size <= 1 || g_rank != 0) return solve_operator_here(op, d, c, options, x, fx);
    check_kept_operator(op);
    if (options.solver != SolverKind::jacobi && options.solver != SolverKind::gmres)
        throw OptionError("solver",
                          fmt::format("{} needs the entries of F; the hierarchical operator is "
                                      "solved by gmres or jacobi",
                                      to_string(options.solver)));
    const SolveJob job = SolveJob::of(op.id, d, c, options);
    broadcast_command(kCommandOperatorSolve, solve_job_bytes(job));
    MpiChain chain;
    try {
        return solve_operator_kept(kept_operator().get(), 0, chain, static_cast<Eigen::Index>(op.n),
                                   d, c, options, x, fx);
    } catch (const RankStopped& e) {
        throw_stopped(e);
    }
}

}  // namespace formfactor::distributed
