#pragma once
// The solvers on rows of F spread over ranks (formfactor/distributed/distributed.h): each rank
// holds the blocks of rows it computed, and every rank runs the same iteration on the whole
// solution vector, which is small (N × channels) beside F. A product F x is each rank's rows,
// then an exchange that gives every rank every row; the rest of the iteration (norms, GMRES's
// dot products and least-squares) runs identically on every rank on identical vectors. So the
// result does not depend on which rank holds which rows, and every row of F x is summed as one
// process sums it: Jacobi and GMRES give the single process's solution bit for bit.
//
// Gauss–Seidel is sequential over all rows; here each block of rows is swept in order from the
// values every block had at the start of the sweep (block Jacobi between blocks, Gauss–Seidel
// within one). The blocks are the row blocks the computation of F handed out, whose bounds
// depend on the number of ranks only: a fixed rank count gives bit-identical results, and any
// count stops at the same residual tolerance as one process.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/solve/solver.h"
#include "solve/linear_system.h"

namespace formfactor::distributed {

using detail::Columns;

/// Rows [rows.begin, rows.end) of F kept by this rank: dense (rows × n values, each row at the
/// address alignment it has in the whole N × N matrix, so that Eigen sums a row in the same
/// order as one process does), or CSR with the rows counted from 0 and global columns.
struct KeptBlock {
    RowRange rows;
    std::vector<double> storage;  ///< dense: the values from storage[offset]
    std::size_t offset = 0;
    std::vector<std::int64_t> indptr;  ///< sparse
    std::vector<std::int32_t> indices;
    std::vector<double> values;

    /// Dense: row i (global index) of the block.
    const double* row(std::size_t i, std::size_t n) const {
        return storage.data() + offset + (i - rows.begin) * n;
    }
};

/// The rows this rank holds.
struct KeptRows {
    bool sparse = false;
    std::size_t n = 0;
    std::vector<KeptBlock> blocks;  ///< ascending rows
};

/// Copies m = rows.size() dense rows of n values into a kept block.
KeptBlock keep_dense(RowRange rows, const double* data, std::size_t n);

/// Thresholds sparse rows into a kept block as SparseBuilder does (entries > threshold are
/// stored); `dropped_max` becomes the largest dropped mass of its rows.
KeptBlock keep_sparse(SparseRows rows, std::size_t n, double threshold, int threads,
                      double& dropped_max);

/// Σ_j F_ij of each row of the block, summed as the single-process solvers sum them.
std::vector<double> kept_row_sums(const KeptBlock& block, std::size_t n, bool sparse);

/// The stored entries of the block (n per row when dense).
std::size_t kept_entries(const KeptBlock& block, std::size_t n, bool sparse);

/// The row blocks of every rank (ascending within a rank).
using Owners = std::vector<std::vector<RowRange>>;

/// A block of kept rows that changes rank.
struct Move {
    RowRange rows;
    std::int32_t from = 0, to = 0;
};

/// The moves that even out the work of a product over the ranks (weights: per block, by its
/// first row), applied to `owners`. Each block moves at most once, from the rank that holds
/// it: a rank gives only blocks it has before the moves.
std::vector<Move> balancing_moves(Owners& owners, const std::map<std::size_t, double>& weights);

/// How a rank is doing as an iteration's vector is exchanged.
enum class RankStatus : int { fine = 0, cancelled = 1, failed = 2 };

/// What an exchange learnt of the other ranks.
struct Exchanged {
    RankStatus status = RankStatus::fine;  ///< the worst of every rank
    int rank = 0;                          ///< the first rank with that status
    double change = 0.0;                   ///< the largest change of every rank
};

/// Gives every rank every row of x: each rank has filled its own rows (its KeptRows, which the
/// exchange knows as the Owners of every rank), the others' rows are overwritten. Every rank calls
/// it the same number of times.
class Exchange {
  public:
    virtual ~Exchange() = default;
    virtual Exchanged exchange(Columns& x, RankStatus status, double change) = 0;
};

/// Thrown by solve_kept() on every rank when some rank failed or was interrupted: the failing
/// rank keeps its own error in `own` (empty on the others).
class RankStopped : public std::runtime_error {
  public:
    RankStopped(Exchanged e, std::string own)
        : std::runtime_error("a rank stopped"), state(e), own_message(std::move(own)) {}
    Exchanged state;
    std::string own_message;
};

/// x = c + diag(d) F x over rows held by every rank (jacobi, gauss-seidel or gmres): every rank
/// calls it with the same d, c and options and gets the same x, and fx = F x. Throws
/// OptionError("solver") for direct and shooting, Error when not converged (on every rank
/// alike), RankStopped when a rank failed or was interrupted.
SolverStats solve_kept(const KeptRows& rows, int rank, Exchange& exchange, const Columns& d,
                       const Columns& c, const SolverOptions& options, Columns& x, Columns& fx);

/// The rows this process kept in the last compute_distributed_rows(), and that computation's id.
KeptRows& kept_rows();
std::uint64_t& kept_id();

/// compute_distributed_rows() and solve_rows() on this process alone (one rank).
DistributedRows compute_rows_here(const Scene& scene, const ComputeOptions& options,
                                  const SparseOptions* sparse);
SolverStats solve_rows_here(const DistributedRows& rows, const Columns& d, const Columns& c,
                            const SolverOptions& options, Columns& x, Columns& fx);

/// A whole F that distribute_rows() cuts into blocks: what rank 0 knows of it (everything of
/// DistributedRows but the row sums, the ranks' rows and the id), the blocks (one per rank,
/// contiguous and ascending, empty for a rank when there are fewer rows than ranks) and a copy
/// of any block of rows.
struct WholeRows {
    DistributedRows head;
    std::vector<RowRange> blocks;
    std::function<KeptBlock(RowRange)> block;
};
WholeRows whole_rows(const FormFactors& F, int ranks);
WholeRows whole_rows(const SparseFormFactors& F, int ranks);

/// distribute_rows() on this process alone: one block of every row.
DistributedRows distribute_rows_here(const WholeRows& whole);

/// Throws Error unless `rows` are the ones this process keeps.
void check_kept(const DistributedRows& rows);

/// The linear solve of the rows the last compute_distributed_rows() kept, on rank 0 (which
/// makes every rank join it): solve_kept() with the MPI exchange, or on one process its own.
/// Throws Error("rank K: ...") when rank K failed, Cancelled when a rank was interrupted.
SolverStats solve_rows(const DistributedRows& rows, const Columns& d, const Columns& c,
                       const SolverOptions& options, Columns& x, Columns& fx);

}  // namespace formfactor::distributed
