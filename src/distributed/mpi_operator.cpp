// The hierarchical operator spread over the ranks (build_hierarchical(), solve_operator(),
// multiply_operator(); hierarchical_solve.h), commands of their own: every rank makes the
// partition, computes its share of the blocks and sends the others theirs, and its solves and
// products hand a product's running sums from rank to rank in chunk order. Its steps end with
// agree(), an all-gather of every rank's status.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <numeric>
#include <optional>

#include "formfactor/core/cancel.h"
#include "formfactor/core/timing.h"
#include "formfactor/matrix/memory.h"
#include "mpi_internal.h"

namespace formfactor::distributed {

namespace {

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

// Y = F X over the ranks, every rank with the same X: each rank's partial products of its
// chunks (`injected`: a failure for the tests), the running sums handed on in chunk order, then
// agree(). Rank 0 gets Y or throws the first rank's failure; the others return false after one.
bool product_on_ranks(const Columns& X, int threads, const std::string& injected, Columns& Y) {
    std::string failure;
    bool cancelled = false;
    const HierarchicalFormFactors* part = kept_operator().get();
    HierarchicalFormFactors::Partials own;
    guarded_step(
        [&] {
            if (!injected.empty()) throw Error(injected);
            if (!part) throw Error("distributed: this rank holds no hierarchical operator");
            own = part->partial_products(X, threads);
        },
        failure, cancelled);
    MpiChain chain;
    chain.product(part, own, X.rows(), X.cols(),
                  cancelled         ? RankStatus::cancelled
                  : failure.empty() ? RankStatus::fine
                                    : RankStatus::failed,
                  Y);
    // The chain told every rank whether all went well; agree() tells rank 0 which rank and why.
    return agree(failure, cancelled);
}

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

    // This rank's share against this rank's machine, before any entry is computed: the blocks
    // it computes and its run of chunks, not the whole operator.
    const double estimate = plan->estimate_memory(mine, ranks).total();
    guarded_step([&] { plan->check_memory(mine, ranks, available_memory()); }, failure, cancelled);
    if (!agree(failure, cancelled)) return out;

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
        sizes[r] = static_cast<int>(5 + 3 * built_by[r].size());
        displs[r] = static_cast<int>(total);
        total += static_cast<std::size_t>(sizes[r]);
    }
    std::vector<double> mine_sent{partition, busy, double(counts.entries_computed),
                                  double(counts.low_rank_fallbacks), estimate};
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
    out.estimated_bytes.assign(ranks, 0.0);
    for (std::size_t r = 0; r < ranks; ++r) {
        const double* p = got.data() + displs[r];
        out.partition_seconds[r] = p[0];
        out.build_seconds[r] = p[1];
        out.blocks_built[r] = double(built_by[r].size());
        st.entries_computed += static_cast<std::size_t>(p[2]);
        st.low_rank_fallbacks += static_cast<std::size_t>(p[3]);
        out.estimated_bytes[r] = p[4];
        p += 5;
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
    Columns sums;
    if (!product_on_ranks(Columns::Ones(n, 1), options.threads, {}, sums)) return out;
    st.seconds = wall.seconds();
    out.n = scene.patches.size();
    out.areas = plan->areas();
    out.row_sums.assign(sums.data(), sums.data() + n);
    out.stats = st;
    out.id = id;
    return out;
}

}  // namespace

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
// A worker's part of a product on the operator (multiply_operator()): X from rank 0, then
// product_on_ranks().
void work_on_operator_product(const std::vector<char>& bytes) {
    std::string failure;
    bool cancelled = false;
    int threads = 0;
    Columns X, Y;
    guarded_step(
        [&] {
            WireReader r(bytes.data(), bytes.size());
            if (r.get<std::uint64_t>() != kept_operator_id() || !kept_operator())
                throw Error("distributed: the hierarchical operator is not the one kept");
            threads = r.get<int>();
            X = get_columns(r);
        },
        failure, cancelled);
    if (!agree(failure, cancelled)) return;
    try {
        product_on_ranks(X, threads, injected_product_failure(g_rank), Y);
    } catch (const std::exception&) {
        // A product too large for a message: rank 0 meets the same and reports it.
    }
}

DistributedHierarchical build_hierarchical(const Scene& scene, const HierarchicalOptions& options) {
    if (g_size <= 1 || g_rank != 0) return build_operator_here(scene, options);
    // Bad options as one process reports them (an OptionError), before any rank starts.
    check_hierarchical_options(options);
    const CancellationScope scope(process_cancellation());
    const std::uint64_t id = ++kept_operator_id();
    broadcast_command(kCommandOperator, hierarchical_job_bytes(id, options, scene));
    return build_on_ranks(scene, options, id);
}

void multiply_operator(const DistributedHierarchical& op, const Columns& X, int threads,
                       Columns& Y) {
    if (g_size <= 1 || g_rank != 0) return multiply_operator_here(op, X, threads, Y);
    check_kept_operator(op);
    FF_ASSERT(X.rows() == static_cast<Eigen::Index>(op.n));
    const CancellationScope scope(process_cancellation());
    WireWriter w;
    w.put(op.id);
    w.put(threads);
    put_columns(w, X);
    broadcast_command(kCommandOperatorProduct, w.bytes());
    agree({}, false);
    product_on_ranks(X, threads, injected_product_failure(0), Y);
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
