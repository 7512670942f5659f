// Solves over the ranks: of rows of F kept apart (solve_rows()), where every rank iterates on
// its rows with one all-gather per product (row_solve.h), and the solve job that the operator's
// solves (mpi_operator.cpp) send too. A solve is a command of its own: rank 0 sends the system,
// and every rank runs the same iteration.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <limits>

#include "mpi_internal.h"

namespace formfactor::distributed {

namespace {

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

}  // namespace

void put_columns(WireWriter& w, const Columns& m) {
    w.put<std::int64_t>(m.rows());
    w.put<std::int64_t>(m.cols());
    w.put_array(m.data(), static_cast<std::size_t>(m.size()));
}

Columns get_columns(WireReader& r) {
    const auto rows = r.get<std::int64_t>(), cols = r.get<std::int64_t>();
    const std::vector<double> v = r.get_vector<double>();
    if (rows < 0 || cols < 0 || v.size() != static_cast<std::size_t>(rows * cols))
        throw Error("distributed: columns of the wrong size");
    Columns m(rows, cols);
    std::copy(v.begin(), v.end(), m.data());
    return m;
}

std::vector<char> solve_job_bytes(const SolveJob& job) {
    WireWriter w;
    w.put(job.kept);
    w.put<std::uint64_t>(job.owners.size());
    for (const auto& blocks : job.owners) w.put_vector(blocks);
    put_columns(w, job.d);
    put_columns(w, job.c);
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
    job.d = get_columns(r);
    job.c = get_columns(r);
    if (job.c.rows() != job.d.rows() || job.c.cols() != job.d.cols())
        throw Error("distributed: a system of the wrong size");
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

}  // namespace formfactor::distributed
