#pragma once
// The solvers on the hierarchical operator spread over ranks (formfactor/distributed/
// distributed.h): each rank holds the blocks of a run of the operator's fixed chunks
// (HierarchicalFormFactors::part()), and every rank runs the same iteration on the whole
// solution vector. A product is each rank's partial products, then a chain: rank 0 adds its
// chunks to zero and hands the running sums to rank 1, which adds its own, and so on; the last
// rank makes the product and every rank gets it. Every chunk is added in the order one process
// adds them (each rank's partials are computed before the running sums arrive, so the chain
// only adds), and the partials are the same bits whichever rank holds the blocks, so the
// product, and with it the solution, is one process's bit for bit.

#include <cstdint>
#include <memory>
#include <string>

#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/hierarchical.h"
#include "row_solve.h"

namespace formfactor::distributed {

/// Hands the running sums of a product from rank to rank in chunk order (the header).
class ChunkChain {
  public:
    virtual ~ChunkChain() = default;
    /// Y = F X on every rank: `own` (this rank's partial products, empty after a failure) added
    /// to the sums of the ranks before, `part` finishing the product on the last rank (null on
    /// a rank that holds no operator: it must not be the last). `status` is this rank's; the
    /// worst over the ranks comes back, and Y only when every rank is fine.
    virtual Exchanged product(const HierarchicalFormFactors* part,
                              const HierarchicalFormFactors::Partials& own, Eigen::Index n,
                              Eigen::Index k, RankStatus status, Columns& Y) = 0;
};

/// The part of the operator this process holds since the last build_hierarchical(), and that
/// build's id.
std::unique_ptr<HierarchicalFormFactors>& kept_operator();
std::uint64_t& kept_operator_id();

/// x = c + diag(d) F x with F the operator spread over the ranks (jacobi or gmres): every rank
/// calls it with the same d, c and options and gets the same x, and fx = F x. `part` null (this
/// rank lost its part) fails in the first product. Throws OptionError("solver") for the other
/// solvers, Error when not converged, RankStopped when a rank failed or was interrupted.
SolverStats solve_operator_kept(const HierarchicalFormFactors* part, int rank, ChunkChain& chain,
                                Eigen::Index n, const Columns& d, const Columns& c,
                                const SolverOptions& options, Columns& x, Columns& fx);

/// build_hierarchical() and the solve on this process alone (one rank).
DistributedHierarchical build_operator_here(const Scene& scene, const HierarchicalOptions& options);
SolverStats solve_operator_here(const DistributedHierarchical& op, const Columns& d,
                                const Columns& c, const SolverOptions& options, Columns& x,
                                Columns& fx);

/// Y = F X on this process alone (one rank).
void multiply_operator_here(const DistributedHierarchical& op, const Columns& X, int threads,
                            Columns& Y);

/// Y = F X of the operator of the last build_hierarchical(), on rank 0 (which makes every rank
/// join it, sending them X); on one process its own. Throws Error("rank K: ...") when rank K
/// failed, Cancelled when a rank was interrupted.
void multiply_operator(const DistributedHierarchical& op, const Columns& X, int threads,
                       Columns& Y);

/// For the tests of a rank failing in a product on the operator (a solve's, or the per-surface
/// products): FORMFACTOR_TEST_FAIL_SOLVE_RANK=K gives rank K the failure's message, empty on
/// the other ranks.
std::string injected_product_failure(int rank);

/// Throws Error unless `op` is the operator this process keeps.
void check_kept_operator(const DistributedHierarchical& op);

/// The linear solve on the operator of the last build_hierarchical(), on rank 0 (which makes
/// every rank join it); on one process its own.
SolverStats solve_operator(const DistributedHierarchical& op, const Columns& d, const Columns& c,
                           const SolverOptions& options, Columns& x, Columns& fx);

}  // namespace formfactor::distributed
