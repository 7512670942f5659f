// Rank 0's side of a job of rows over the ranks. Rank 0 broadcasts a job (the scene and the
// method's options), then a dispatcher thread hands out row blocks and receives the rows while
// rank 0's main thread computes blocks of its own; the other ranks wait in serve(). Every
// message a worker sends (ready, rows, failure) is answered by one assignment: a block, or
// none (the job is over for it).
//
// The analytic method in a scene that may obstruct runs a job in three stages: the
// classification's tasks (pairs of plane groups) are handed out and rank 0 sends every rank the
// whole classification (the same list everywhere); the partly hidden pairs are handed out in
// parts of the list and integrated once over the ranks, and rank 0 sends every rank all their
// values; the rows then take them (formfactor/methods/partly_hidden.h). By rows alone, a pair
// between two blocks would be integrated for each block.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "formfactor/core/progress.h"
#include "formfactor/core/timing.h"
#include "formfactor/scene/obstruction.h"
#include "mpi_internal.h"

namespace formfactor::distributed {

namespace {

// The analytic method's partly hidden pairs are worth a stage of their own (the header).
bool uses_pair_stage(MethodKind method, const Scene& scene) {
    return method == MethodKind::analytic && !scene.patches.empty() &&
           formfactor::may_obstruct(scene);
}

}  // namespace

bool keeps_rows(JobKind kind) {
    return kind == JobKind::kept_dense || kind == JobKind::kept_sparse;
}
bool sparse_job(JobKind kind) { return kind == JobKind::sparse || kind == JobKind::kept_sparse; }

namespace {

std::vector<char> job_bytes(const Job& job, const Scene& scene) {
    WireWriter w;
    w.put(job.kind);
    w.put(job.method);
    w.put(job.method_options);
    w.put(job.visibility);
    w.put(job.threshold);
    w.put(job.kept);
    w.put<std::uint8_t>(job.pairs_first);
    w.put<std::uint8_t>(job.upper_only);
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
    std::vector<char> bytes;  // each message in turn, in memory already mapped
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
        receive_bytes(probed, bytes);
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
// The sink's prepare() runs first on rank 0's main thread, its first block taken and the
// dispatcher already answering; then `prepare`, when set, which opens the schedule.
void run_stage(Schedule& schedule, BlockSink& sink, Failure& failure, CancellationFlag& job_cancel,
               Progress& progress, std::vector<double>& rows, std::vector<double>& busy,
               const std::function<void()>& prepare = {}) {
    // Rank 0's first block before any other: it gives the areas (the rows' stage).
    std::optional<RowRange> block;
    if (!prepare) block = schedule.take();
    auto compute_local = [&](bool only_first) {
        try {
            sink.prepare();
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

}  // namespace

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

namespace {

// The first stage's parts of the partly hidden pairs, by their first position.
class PairSink final : public BlockSink {
  public:
    PairSink(const PartlyHiddenPairs* pairs, const CancellationFlag& cancel)
        : pairs_(pairs), cancel_(cancel) {}
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

// The classification's tasks, by their first task (bytes of PartlyHiddenPairs::classify()).
class ClassificationSink final : public BlockSink {
  public:
    ClassificationSink(const CancellationFlag& cancel) : cancel_(cancel) {}
    void set_pairs(const PartlyHiddenPairs* pairs) { pairs_ = pairs; }
    void local(const RowRange& tasks) override {
        const CancellationScope scope(cancel_);
        std::vector<char> bytes = pairs_->classify(tasks);
        const std::lock_guard lock(mutex_);
        parts_[tasks.begin] = {tasks.end, std::move(bytes)};
    }
    void remote(int from, const RowRange& tasks, WireReader& r) override {
        (void)from;
        std::vector<char> bytes = r.get_vector<char>();
        const std::lock_guard lock(mutex_);
        parts_[tasks.begin] = {tasks.end, std::move(bytes)};
    }
    /// `lead`, then every part in order (once every part is in); `count` tasks in all.
    std::vector<char> all(std::size_t count, char lead) {
        std::size_t size = 1;
        for (const auto& [first, part] : parts_) size += part.second.size();
        std::vector<char> out;
        out.reserve(size);
        out.push_back(lead);
        std::size_t next = 0;
        for (auto& [first, part] : parts_) {
            if (first != next) throw Error("distributed: a part of the classification is missing");
            out.insert(out.end(), part.second.begin(), part.second.end());
            part.second = std::vector<char>{};
            next = part.first;
        }
        if (next != count) throw Error("distributed: a part of the classification is missing");
        return out;
    }

  private:
    const PartlyHiddenPairs* pairs_ = nullptr;
    const CancellationFlag& cancel_;
    std::mutex mutex_;
    std::map<std::size_t, std::pair<std::size_t, std::vector<char>>> parts_;
};

// Rank 0: the classification of the partly hidden pairs (the first part of the pair stage),
// shared out over the ranks by its tasks (pairs of plane groups) as rows are; every worker then
// gets the whole of it (message: 1 and the bytes), or, when it is more than MPI sends at once,
// word to classify it itself (2), or to stop (0). Returns the pairs, classified, or null
// after a failure (recorded in `failure`).
std::unique_ptr<PartlyHiddenPairs> run_classification(const Job& job, const Scene& scene,
                                                      Failure& failure,
                                                      CancellationFlag& job_cancel,
                                                      ProgressSink* progress_sink,
                                                      std::vector<double>& busy) {
    std::unique_ptr<PartlyHiddenPairs> pairs;
    Schedule schedule(g_size);
    ClassificationSink sink(job_cancel);
    std::vector<double> done(static_cast<std::size_t>(g_size), 0.0);
    std::optional<Progress> progress;
    progress.emplace("classification", 0, nullptr);
    // Rank 0 prepares the blockers while the dispatcher takes the workers' first word.
    auto prepare = [&] {
        {
            const CancellationScope scope(job_cancel);
            pairs = std::make_unique<PartlyHiddenPairs>(scene, job.method_options,
                                                        sparse_job(job.kind), false);
        }
        sink.set_pairs(pairs.get());
        const std::size_t tasks = pairs->classification_tasks();
        progress.emplace("classification", tasks, progress_sink);
        // The tasks come costliest first (PartlyHiddenPairs::classify()): a few at a time, so
        // that no rank takes several costly ones while another runs out (room-32: the 15 pairs
        // of walls hold all the work, 0.1 to 0.6 s each).
        schedule.open(tasks, std::max<std::size_t>(1, tasks / (64 * std::size_t(g_size))), false);
    };
    run_stage(schedule, sink, failure, job_cancel, *progress, done, busy, prepare);
    if (!failure.any()) progress->finish();
    progress.reset();
    std::vector<char> message(1, 0);  // 0: stop
    if (!failure.any() && !process_cancellation().requested()) {
        try {
            message = sink.all(pairs->classification_tasks(), 1);
            pairs->set_classification(message.data() + 1, message.size() - 1);
            if (message.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
                message.assign(1, 2);
        } catch (...) {
            failure.record_local(std::current_exception());
            message.assign(1, 0);
        }
    }
    for (int r = 1; r < g_size; ++r) send_bytes(message, r, kTagValues);
    if (message[0] == 0) return nullptr;
    return pairs;
}

// Rank 0: the pair stage of a job (uses_pair_stage()). The ranks classify (run_classification());
// the parts of the list go out as rows do; then every worker gets every value (or, when a rank
// failed, word to stop) and `pairs` holds them. Returns the pairs, null after a failure
// (recorded in `failure`).
std::unique_ptr<PartlyHiddenPairs> run_pair_stage(const Job& job, const Scene& scene,
                                                  Failure& failure, CancellationFlag& job_cancel,
                                                  ProgressSink* progress_sink) {
    std::vector<double> classified(static_cast<std::size_t>(g_size), 0.0);
    std::unique_ptr<PartlyHiddenPairs> pairs =
        run_classification(job, scene, failure, job_cancel, progress_sink, classified);
    if (!pairs) return nullptr;
    // Parts shrink as the pairs run out; each is a sample of the list (partly_hidden.h), so
    // its cost follows its size.
    Schedule schedule(pairs->count(), g_size, pairs->count(), false);
    PairSink sink(pairs.get(), job_cancel);
    std::vector<double> done(static_cast<std::size_t>(g_size), 0.0), busy = classified;
    Progress progress("partly hidden pairs", pairs->count(), progress_sink);
    run_stage(schedule, sink, failure, job_cancel, progress, done, busy);
    if (!failure.any()) progress.finish();
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

}  // namespace

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
    if (failure.any()) failure.rethrow();
    process_cancellation().throw_if_requested();
    sink.finish();
    sink.partly_hidden = nullptr;
    progress.finish();
    g_shares.rows = rows;
    for (std::size_t r = 0; r < busy.size(); ++r) g_shares.busy_seconds[r] += busy[r];
    g_shares.blocks = schedule.blocks();
    g_shares.largest_block = schedule.largest();
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

}  // namespace formfactor::distributed
