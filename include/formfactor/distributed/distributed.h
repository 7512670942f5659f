#pragma once
/// Computing F over several MPI ranks (DESIGN.md, "Scale"; docs/cluster.md). One program runs
/// on every rank; rank 0 does what a single process does (reads the scene, writes the outputs)
/// and, where it computes F, hands blocks of rows to the other ranks, which wait in serve():
///
///     formfactor::distributed::Session mpi(argc, argv);   // MPI only when mpirun started us
///     if (mpi.rank() > 0) return formfactor::distributed::serve();
///     ... load the scene, then on rank 0:
///     const formfactor::ComputeResult r = formfactor::distributed::compute_form_factors(scene, o);
///     ... write r; finally
///     formfactor::distributed::finish();                   // the other ranks return from serve()
///
/// The scene (with its patches) is broadcast from rank 0 with the method's options; rows are
/// handed out dynamically from rank 0 in blocks that shrink as the rows run out (guided
/// scheduling: a rank that drew costly rows, near obstructions, simply asks less often), and
/// rank 0 computes blocks too. Every block is the pipeline's row range, bit-identical to the
/// same rows of the whole matrix, so the result does not depend on the number of ranks or
/// threads. An error on any rank ends the computation on every rank and is thrown on rank 0 as
/// "rank K: message"; no rank writes anything.
///
/// Without MPI at configure time (FF_MPI off), or in a process not started by an MPI launcher,
/// there is one rank and these calls are the pipeline's own. A build without MPI that mpirun
/// starts K times anyway takes its rank from the launcher's environment: rank 0 does all the
/// work alone and the others return from serve() at once.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/matrix/hierarchical.h"
#include "formfactor/methods/hierarchical_build.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/thermal.h"

namespace formfactor::distributed {

/// True when the library was built with MPI.
bool built_with_mpi();

/// MPI for the life of a program: initialises MPI (threads: serialized) when the environment
/// shows an MPI launcher (mpirun, mpiexec, srun with PMI/PMIx), and finalises it at the end.
/// A process started without one is a single rank and never touches MPI. One per process.
class Session {
  public:
    Session(int& argc, char**& argv);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    int rank() const;
    int size() const;
};

/// For a program that owns MPI (Python with mpi4py): the calls below run over the ranks of the
/// communicator whose Fortran handle is `fortran_handle` (mpi4py: `comm.py2f()`) until the
/// scope ends, then over what they ran on before. Every rank of the communicator opens one;
/// rank 0 makes the calls, the others serve(); the end of rank 0's scope releases them (as
/// finish()). MPI must be initialised and not finalised (Error otherwise; Error also when the
/// library was built without MPI).
class Communicator {
  public:
    explicit Communicator(std::int64_t fortran_handle);
    ~Communicator();
    Communicator(const Communicator&) = delete;
    Communicator& operator=(const Communicator&) = delete;

  private:
    struct Saved;
    std::unique_ptr<Saved> saved_;
};

/// This process's rank (0 without MPI) and the number of ranks (1 without MPI).
int rank();
int size();

/// Ranks other than 0: does rank 0's jobs (compute_form_factors(),
/// compute_sparse_form_factors()) until rank 0 calls finish(); returns 0. A job that fails
/// here is reported to rank 0, which throws it; this rank then waits for the next job. Throws
/// Cancelled when this process is interrupted (SIGINT / SIGTERM) while it waits.
int serve();

/// Rank 0: the other ranks return from serve(). Call it once, on every way out (after an error
/// too, after printing it); nothing on a single rank.
void finish();

/// What the ranks did in the last computation of this process (rank 0): rows and busy seconds
/// per rank, and the blocks handed out. Empty on a single rank.
struct RankShares {
    std::vector<double> rows;
    std::vector<double> busy_seconds;  ///< rows and partly hidden pairs
    std::size_t blocks = 0;
    std::size_t largest_block = 0;  ///< rows of the largest block of rows
    /// The analytic method in a scene that may obstruct: partly hidden pairs integrated per
    /// rank (before the rows), and the parts of the list they were handed out in; else empty.
    std::vector<double> pairs;
    std::size_t pair_blocks = 0;
    /// (largest busy time − mean) / mean: 0 when the ranks were equally busy.
    double imbalance() const;
};
const RankShares& last_rank_shares();

/// compute_form_factors() (formfactor/pipeline.h) over every rank, called on rank 0 only
/// (the others in serve()): the whole matrix, its diagnostics and repair on rank 0, bit-identical
/// to one process. options.rows must be every row (OptionError("rows") otherwise); the report's
/// counts are summed over the blocks. On one rank: the pipeline's compute_form_factors().
ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options);

/// compute_sparse_form_factors() (formfactor/pipeline_sparse.h) over every rank, called on rank
/// 0 only: each rank computes rows into sparse rows (the entries that are not 0), rank 0
/// thresholds them into CSR in row order, diagnoses and repairs, bit-identical to one process.
/// sparse.block_rows and sparse.block_memory bound the blocks. On one rank: the pipeline's.
SparseComputeResult compute_sparse_form_factors(const Scene& scene, const ComputeOptions& options,
                                                const SparseOptions& sparse);

/// F whose rows stay on the ranks that computed them, as rank 0 knows it: what the solvers and
/// a report need of F without its entries. The rows themselves live on their ranks until the
/// next computation.
struct DistributedRows {
    bool sparse = false;           ///< CSR rows (entries above `threshold`), else dense rows
    std::size_t n = 0;             ///< N patches
    std::vector<double> areas;     ///< A_i
    std::vector<double> row_sums;  ///< Σ_j F_ij per row (sparse: over the stored entries)
    double dropped_max = 0.0;      ///< sparse: the largest mass a row's threshold dropped
    double entries = 0.0;          ///< stored entries over every rank (N² when dense)
    double threshold = 0.0;        ///< sparse: entries F_ij ≤ threshold were dropped
    MethodReport report;           ///< the method's, counts summed over the blocks
    MethodTraits traits;
    StepTimes timings;
    int threads = 1;
    /// Rows each rank holds for the solve (moved after the computation so that every rank has
    /// about the same share of a product: rows when dense, stored entries when sparse).
    std::vector<double> rows_per_rank;
    std::uint64_t id = 0;  ///< which computation's rows (a solve of older rows is an Error)
};

/// Rank 0: F of `scene` over every rank (the others in serve()) as compute_form_factors() and
/// compute_sparse_form_factors() compute it, bit-identical, but each rank keeps the rows it
/// computed and sends rank 0 only their row sums: no rank holds the whole F. Blocks then move
/// between ranks (never through rank 0) to even out the work of a product. `sparse` null:
/// dense rows; else CSR rows above sparse->threshold. No repair (options.repair must be none:
/// OptionError("repair")) and no diagnosis of reciprocity (it needs F_ji beside F_ij). On one
/// rank the rows stay in this process.
DistributedRows compute_distributed_rows(const Scene& scene, const ComputeOptions& options,
                                         const SparseOptions* sparse);

/// Rank 0: a whole F that this process already holds (dense, or CSR) cut into one block of
/// contiguous rows per rank and sent to the ranks (the others in serve()), which keep them for
/// solve_thermal() and solve_radiosity() below as compute_distributed_rows() leaves its rows.
/// The blocks carry about equal work of a product (rows when dense, rows and stored entries when
/// sparse), so their bounds depend on F and the number of ranks only. F is not changed; rank 0
/// holds a copy of its own block (and, while sending, of one other). Error for a block of rows
/// (FormFactors::is_block()). On one rank the copy stays in this process.
DistributedRows distribute_rows(const FormFactors& F);
DistributedRows distribute_rows(const SparseFormFactors& F);

/// solve_thermal() (formfactor/solve/thermal.h) on rows spread over the ranks, called on rank 0:
/// every rank iterates on its own rows and the solution vector is exchanged after every product
/// or sweep. options.solver.solver: gmres and jacobi give one process's result bit for bit;
/// gauss-seidel sweeps each row block in order from the values all blocks had at the start of
/// the sweep (block Jacobi between blocks), bit-identical for a fixed number of ranks and within
/// the residual tolerance of one process's; direct and shooting: OptionError("solver").
ThermalResult solve_thermal(const DistributedRows& rows, const PatchProperties& props,
                            const ThermalOptions& options);

/// solve_radiosity() on rows spread over the ranks, as solve_thermal() above.
RadiosityResult solve_radiosity(const DistributedRows& rows, const PatchProperties& props,
                                const SolverOptions& options);

/// The pipeline's solve() (formfactor/pipeline_solve.h) on rows spread over the ranks, called
/// on rank 0: solve_radiosity() or solve_thermal() above, as options asks.
SolveResult solve(const Scene& scene, const DistributedRows& rows, const PatchProperties& props,
                  const SolveOptions& options);

/// The hierarchical operator (formfactor/matrix/hierarchical.h) spread over the ranks, as rank 0
/// knows it: what the solvers and a report need; the blocks live on their ranks until the next
/// build_hierarchical() of this process.
struct DistributedHierarchical {
    std::size_t n = 0;             ///< N patches
    std::vector<double> areas;     ///< A_i
    std::vector<double> row_sums;  ///< Σ_j F_ij per row (F·1 over the ranks, one process's bits)
    HierarchicalStats stats;       ///< the whole operator's (bytes: over every rank)
    /// Per rank: seconds making the partition (every rank makes all of it), blocks computed,
    /// seconds busy computing them, and the blocks, chunks and share of a product's work
    /// (values, rows and columns of its blocks) it holds.
    std::vector<double> partition_seconds, blocks_built, build_seconds, blocks_held, chunks_held,
        product_work;
    /// Per rank: the bytes it was estimated to hold at its peak, which the memory check before
    /// the build held against its machine's memory: its share of the blocks and what every
    /// rank holds whole (HierarchicalPlan::estimate_memory()); empty on one rank.
    std::vector<double> estimated_bytes;
    double moved_bytes = 0.0;  ///< block values sent between ranks after the build
    std::uint64_t id = 0;      ///< which build (a solve of an older one is an Error)
    /// (largest build seconds − mean) / mean.
    double build_imbalance() const;
};

/// Rank 0: build_hierarchical() (formfactor/methods/hierarchical_build.h) over every rank (the
/// others in serve()). Every rank makes the cluster tree and the partition (the same on every
/// rank), computes a share of the blocks (the largest estimated cost first, each to the rank
/// with the least so far), and the blocks then move so that each rank holds a run of the
/// operator's fixed chunks of about equal product work. Each block is the one a single process
/// computes, bit for bit. On one rank the operator stays in this process. Before any entry is
/// computed each rank checks its own share against its machine's memory
/// (HierarchicalPlan::check_memory()); a rank whose share does not fit stops every rank with a
/// ResourceError's message.
DistributedHierarchical build_hierarchical(const Scene& scene, const HierarchicalOptions& options);

/// solve_thermal() and solve_radiosity() (formfactor/solve/) on the operator spread over the
/// ranks, called on rank 0: every rank runs the same iteration (gmres or jacobi; others:
/// OptionError("solver")); a product F x is each rank's chunks, their partial sums handed from
/// rank to rank in chunk order and the last rank's product sent to every rank, so that it is
/// summed exactly as one process sums it: the result is one process's bit for bit, for any
/// number of ranks and threads.
ThermalResult solve_thermal(const DistributedHierarchical& op, const PatchProperties& props,
                            const ThermalOptions& options);
RadiosityResult solve_radiosity(const DistributedHierarchical& op, const PatchProperties& props,
                                const SolverOptions& options);
/// The pipeline's solve() (formfactor/pipeline_solve.h) on the operator spread over the ranks,
/// called on rank 0: solve_radiosity() or solve_thermal() above, as options asks.
SolveResult solve(const Scene& scene, const DistributedHierarchical& op,
                  const PatchProperties& props, const SolveOptions& options);

/// The pipeline's per_surface() (formfactor/pipeline_solve.h) of the operator spread over the
/// ranks, called on rank 0: one product with every surface's indicator column at once, each
/// rank's chunks added to the running sums in chunk order as for a solve, so the per-surface
/// matrix is one process's bit for bit, for any number of ranks and threads. A failure (or an
/// interruption) on any rank ends every rank's part; rank 0 throws it ("rank K: ...").
SurfaceFormFactors<FormFactors> per_surface(const Scene& scene, const DistributedHierarchical& op,
                                            int threads = 0);

/// Y = F X (X n × k, one column per vector) with the operator spread over the ranks, called on
/// rank 0 (the others in serve()): X is sent to every rank, and each rank's chunks are added to
/// the running sums in chunk order as for a solve, so Y is HierarchicalFormFactors::multiply()'s
/// on one process bit for bit, for any number of ranks and threads. Error when `op` is not the
/// operator of this process's last build_hierarchical(); a failure (or an interruption) on any
/// rank ends every rank's part, and rank 0 throws it ("rank K: ..."). On one rank: this
/// process's product.
void multiply(const DistributedHierarchical& op, const Eigen::MatrixXd& X, Eigen::MatrixXd& Y,
              int threads = 0);

}  // namespace formfactor::distributed
