#pragma once
// What the files of the MPI ranks share (src/distributed/mpi_*.cpp; a library built without MPI
// has single_process.cpp instead): the message tags and commands, this rank's state, the waits
// and message helpers, and the parts of each command that more than one file uses. MPI's
// headers are included by these files alone.

// The C API only: Open MPI's deprecated C++ bindings warn in every build.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1

#include <mpi.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/methods/partly_hidden.h"
#include "formfactor/scene/scene.h"
#include "formfactor/visibility/visibility.h"
#include "hierarchical_solve.h"
#include "row_solve.h"
#include "wire.h"

namespace formfactor::distributed {

constexpr int kTagCommand = 1, kTagResult = 2, kTagAssign = 3, kTagMove = 4, kTagValues = 5,
              kTagChain = 6;
constexpr std::int64_t kCommandJob = 1, kCommandFinish = 2, kCommandSolve = 3, kCommandMove = 4,
                       kCommandScatter = 5, kCommandOperator = 6, kCommandOperatorSolve = 7,
                       kCommandOperatorProduct = 8;
// dense, sparse: the rows go to rank 0; kept_dense, kept_sparse: each rank keeps its rows
// (compute_distributed_rows()) and sends their row sums.
enum class JobKind : std::uint8_t { dense, sparse, kept_dense, kept_sparse };
enum class Status : std::uint8_t { ready, rows, failed, cancelled };
constexpr const char* kOutOfMemory =
    "out of memory: the run needed more memory than this rank's machine could give (use fewer "
    "patches, or free memory)";

// This rank's state (defined in mpi_session.cpp).
extern bool g_active;  // MPI was initialised by a Session, or a Communicator is in scope
extern bool g_finished;
extern int g_rank, g_size, g_thread_level;
extern MPI_Comm g_comm;
extern RankShares g_shares;
extern Owners g_owners;  // rank 0: who keeps which rows of the last compute_distributed_rows()

// ---- Waits and messages (mpi_session.cpp) ----

// Waits for a message from `source` with `tag` without spinning; throws Cancelled when
// `cancel` is requested meanwhile.
MPI_Status wait_for(int source, int tag, const CancellationFlag* cancel);
// Waits for a non-blocking operation without spinning.
void complete(MPI_Request& request, std::chrono::microseconds first,
              std::chrono::microseconds most);
std::vector<char> receive_bytes(const MPI_Status& probed);
// The same into `into`, whose capacity is kept for the next message.
void receive_bytes(const MPI_Status& probed, std::vector<char>& into);
int message_size(const std::vector<char>& bytes);
void send_bytes(const std::vector<char>& bytes, int dest, int tag);
// Rank 0: a command and its bytes to every other rank; a worker receives the bytes.
void broadcast_command(std::int64_t command, const std::vector<char>& bytes);
std::vector<char> receive_job();

// ---- Jobs of rows (mpi_jobs.cpp: rank 0's side; mpi_blocks.cpp: a block's rows) ----

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
    // Dense rows of the analytic method: each block computes its upper-triangle entries only
    // (ComputeOptions::upper_triangle_only) and rank 0 fills the lower triangle, by
    // reciprocity and with the partly hidden pairs' values, so that the blocks cost n² / 2
    // pairs together, as one process does, not n².
    bool upper_only = false;
};

bool keeps_rows(JobKind kind);
bool sparse_job(JobKind kind);

// Where rank 0 puts what the blocks give.
class BlockSink {
  public:
    virtual ~BlockSink() = default;
    /// Rank 0's preparation for its own blocks, once its first block is taken and the other
    /// ranks have theirs (main thread).
    virtual void prepare() {}
    /// Rank 0's own block (main thread).
    virtual void local(const RowRange& rows) = 0;
    /// Rank `from`'s rows as it sent them (dispatcher thread).
    virtual void remote(int from, const RowRange& rows, WireReader& r) = 0;
    /// Once every block is in (rank 0's main thread; partly_hidden still set).
    virtual void finish() {}
    /// For local(): the partly hidden pairs of a job with a pair stage (run_job() sets it).
    const PartlyHiddenPairs* partly_hidden = nullptr;
};

void put_values(WireWriter& w, const PartlyHiddenValues& v);
PartlyHiddenValues get_values(WireReader& r);
// Rank 0: runs a job over the ranks (mpi_jobs.cpp).
void run_job(Job job, const Scene& scene, std::size_t max_rows, BlockSink& sink,
             CancellationFlag& job_cancel, ProgressSink* progress_sink);
void add_shares(MethodReport& report);
ComputeOptions block_options(const Job& job, const Visibility* visibility, RowRange rows,
                             const CancellationFlag* cancel,
                             const PartlyHiddenPairs* partly_hidden);
std::vector<double> keep_block(const Job& job, const Scene& scene, ComputeOptions o,
                               bool emit_sparse, MethodReport& report,
                               std::vector<double>* areas = nullptr);
void work_on_job(const std::vector<char>& bytes);

// ---- Kept rows: their moves between ranks and their scatter (mpi_row_owners.cpp) ----

std::string make_moves(const std::vector<Move>& moves);
std::vector<char> moves_bytes(const std::vector<Move>& moves);
std::vector<std::int32_t> gather_move_status(const std::string& failure);
void throw_move_failures(const std::string& failure, const std::vector<std::int32_t>& status);
void work_on_moves(const std::vector<char>& bytes);
void work_on_scatter(const std::vector<char>& bytes);

// ---- Solves on kept rows and on the operator (mpi_row_solve.cpp) ----

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

// An n × k block of columns on the wire: its size, then its values (column-major).
void put_columns(WireWriter& w, const Columns& m);
Columns get_columns(WireReader& r);
std::vector<char> solve_job_bytes(const SolveJob& job);
SolveJob get_solve_job(const std::vector<char>& bytes);
void tell_own_failure(const RankStopped& e);
[[noreturn]] void throw_stopped(const RankStopped& e);
void work_on_solve(const std::vector<char>& bytes);

// ---- The hierarchical operator over the ranks (mpi_operator.cpp) ----

void work_on_hierarchical(const std::vector<char>& bytes);
void work_on_operator_solve(const std::vector<char>& bytes);
void work_on_operator_product(const std::vector<char>& bytes);

}  // namespace formfactor::distributed
