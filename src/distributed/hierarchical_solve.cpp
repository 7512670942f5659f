// The solvers on the hierarchical operator spread over ranks (hierarchical_solve.h).

#include "hierarchical_solve.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <new>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"

namespace formfactor::distributed {

double DistributedHierarchical::build_imbalance() const {
    if (build_seconds.empty()) return 0.0;
    double sum = 0.0, most = 0.0;
    for (double s : build_seconds) {
        sum += s;
        most = std::max(most, s);
    }
    const double mean = sum / double(build_seconds.size());
    return mean > 0.0 ? (most - mean) / mean : 0.0;
}

std::unique_ptr<HierarchicalFormFactors>& kept_operator() {
    static std::unique_ptr<HierarchicalFormFactors> part;
    return part;
}

std::uint64_t& kept_operator_id() {
    static std::uint64_t id = 0;
    return id;
}

void check_kept_operator(const DistributedHierarchical& op) {
    if (op.id == 0 || op.id != kept_operator_id() || !kept_operator() ||
        kept_operator()->size() != op.n)
        throw Error(
            "the hierarchical operator over the ranks was replaced by a later build (a process "
            "holds one at a time)");
}

std::string injected_product_failure(int rank) {
    const char* fail = std::getenv("FORMFACTOR_TEST_FAIL_SOLVE_RANK");
    if (!fail || std::atoi(fail) != rank) return {};
    return fmt::format("a failure injected on rank {} (FORMFACTOR_TEST_FAIL_SOLVE_RANK)", rank);
}

namespace {

// One rank's products: its partials, then the chain; its own failure kept for the report.
class OperatorRunner {
  public:
    OperatorRunner(const HierarchicalFormFactors* part, int rank, ChunkChain& chain, Eigen::Index n,
                   int threads)
        : part_(part), rank_(rank), chain_(chain), n_(n), threads_(threads) {}

    void apply(const Columns& x, Columns& y) {
        HierarchicalFormFactors::Partials own;
        RankStatus status = RankStatus::fine;
        if (process_cancellation().requested()) {
            status = RankStatus::cancelled;
        } else {
            try {
                if (!injected_.empty()) throw Error(injected_);
                if (!part_) throw Error("distributed: this rank holds no hierarchical operator");
                own = part_->partial_products(x, threads_);
            } catch (const Cancelled&) {
                status = RankStatus::cancelled;
            } catch (const std::bad_alloc&) {
                failure_ =
                    "out of memory: the run needed more memory than this rank's machine could give "
                    "(use fewer patches, or free memory)";
                status = RankStatus::failed;
            } catch (const std::exception& e) {
                failure_ = e.what();
                status = RankStatus::failed;
            }
            if (status != RankStatus::fine) own = HierarchicalFormFactors::Partials{};
        }
        const Exchanged e = chain_.product(part_, own, n_, x.cols(), status, y);
        if (e.status != RankStatus::fine)
            throw RankStopped(e, e.rank == rank_ ? failure_ : std::string());
    }

  private:
    const HierarchicalFormFactors* part_;
    int rank_;
    ChunkChain& chain_;
    Eigen::Index n_;
    int threads_;
    std::string failure_;
    std::string injected_ = injected_product_failure(rank_);
};

// One process: the chain is this process's chunks alone.
class OwnChunks final : public ChunkChain {
  public:
    Exchanged product(const HierarchicalFormFactors* part,
                      const HierarchicalFormFactors::Partials& own, Eigen::Index n, Eigen::Index k,
                      RankStatus status, Columns& Y) override {
        if (status == RankStatus::fine) {
            Columns Yt = Columns::Zero(n, k), Zt = Columns::Zero(n, k);
            HierarchicalFormFactors::add_partials(own, Yt, Zt);
            part->finish_product(Yt, Zt, Y);
        }
        return {status, 0, 0.0};
    }
};

}  // namespace

SolverStats solve_operator_kept(const HierarchicalFormFactors* part, int rank, ChunkChain& chain,
                                Eigen::Index n, const Columns& d, const Columns& c,
                                const SolverOptions& options, Columns& x, Columns& fx) {
    FF_ASSERT(d.rows() == n && c.rows() == n && d.cols() == c.cols());
    if (options.solver != SolverKind::jacobi && options.solver != SolverKind::gmres)
        throw OptionError("solver",
                          fmt::format("{} needs the entries of F; the hierarchical operator is "
                                      "solved by gmres or jacobi",
                                      to_string(options.solver)));
    // Every rank stops together, through the chain: no loop may stop on its own.
    const CancellationFlag never;
    const CancellationScope scope(never);
    OperatorRunner runner(part, rank, chain, n, options.threads);
    const detail::ApplyF apply = [&](const Columns& v, Columns& y) { runner.apply(v, y); };
    const SolverStats st = detail::solve_linear_operator(apply, n, d, c, options, x);
    apply(x, fx);
    return st;
}

DistributedHierarchical build_operator_here(const Scene& scene,
                                            const HierarchicalOptions& options) {
    kept_operator().reset();
    auto H =
        std::make_unique<HierarchicalFormFactors>(formfactor::build_hierarchical(scene, options));
    DistributedHierarchical out;
    out.n = H->size();
    out.areas = H->areas();
    out.stats = H->stats();
    out.row_sums = H->row_sums(options.threads);
    out.blocks_built = {double(out.stats.dense_blocks + out.stats.low_rank_blocks)};
    out.partition_seconds = {0.0};
    out.build_seconds = {out.stats.seconds};
    out.blocks_held = {double(H->blocks())};
    out.chunks_held = {double(H->chunks())};
    out.product_work = {0.0};
    kept_operator() = std::move(H);
    out.id = ++kept_operator_id();
    return out;
}

SolverStats solve_operator_here(const DistributedHierarchical& op, const Columns& d,
                                const Columns& c, const SolverOptions& options, Columns& x,
                                Columns& fx) {
    check_kept_operator(op);
    OwnChunks own;
    try {
        return solve_operator_kept(kept_operator().get(), 0, own, static_cast<Eigen::Index>(op.n),
                                   d, c, options, x, fx);
    } catch (const RankStopped& e) {
        if (e.state.status == RankStatus::cancelled) throw Cancelled();
        throw Error(e.own_message);
    }
}

void multiply_operator_here(const DistributedHierarchical& op, const Columns& X, int threads,
                            Columns& Y) {
    check_kept_operator(op);
    kept_operator()->multiply(X, Y, threads);
}

}  // namespace formfactor::distributed
