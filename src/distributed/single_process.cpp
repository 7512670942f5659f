// One rank (the library built without MPI): formfactor/distributed/distributed.h's calls are
// the pipeline's own.

#include <cstdlib>

#include "formfactor/core/error.h"
#include "formfactor/distributed/distributed.h"
#include "hierarchical_solve.h"
#include "row_solve.h"

namespace formfactor::distributed {

namespace {

// Started by mpirun all the same: the launcher's rank, so that ranks other than 0 leave the
// work (and the output files) to rank 0 instead of each doing all of it.
int g_rank = 0;

}  // namespace

bool built_with_mpi() { return false; }

Session::Session(int& argc, char**& argv) {
    (void)argc;
    (void)argv;
    for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
        if (const char* value = std::getenv(name)) {
            g_rank = std::atoi(value);
            break;
        }
}
Session::~Session() = default;

struct Communicator::Saved {};
Communicator::Communicator(std::int64_t fortran_handle) {
    (void)fortran_handle;
    throw Error("comm: this build of formfactor has no MPI (configured with FF_MPI off)");
}
Communicator::~Communicator() = default;
int Session::rank() const { return g_rank; }
int Session::size() const { return 1; }
int rank() { return g_rank; }
int size() { return 1; }
int serve() { return 0; }
void finish() {}

const RankShares& last_rank_shares() {
    static const RankShares none;
    return none;
}

ComputeResult compute_form_factors(const Scene& scene, const ComputeOptions& options) {
    return formfactor::compute_form_factors(scene, options);
}

SparseComputeResult compute_sparse_form_factors(const Scene& scene, const ComputeOptions& options,
                                                const SparseOptions& sparse) {
    return formfactor::compute_sparse_form_factors(scene, options, sparse);
}

DistributedRows compute_distributed_rows(const Scene& scene, const ComputeOptions& options,
                                         const SparseOptions* sparse) {
    return compute_rows_here(scene, options, sparse);
}

DistributedRows distribute_rows(const FormFactors& F) {
    return distribute_rows_here(whole_rows(F, 1));
}

DistributedRows distribute_rows(const SparseFormFactors& F) {
    return distribute_rows_here(whole_rows(F, 1));
}

SolverStats solve_rows(const DistributedRows& rows, const Columns& d, const Columns& c,
                       const SolverOptions& options, Columns& x, Columns& fx) {
    return solve_rows_here(rows, d, c, options, x, fx);
}

DistributedHierarchical build_hierarchical(const Scene& scene, const HierarchicalOptions& options) {
    return build_operator_here(scene, options);
}

SolverStats solve_operator(const DistributedHierarchical& op, const Columns& d, const Columns& c,
                           const SolverOptions& options, Columns& x, Columns& fx) {
    return solve_operator_here(op, d, c, options, x, fx);
}

void multiply_operator(const DistributedHierarchical& op, const Columns& X, int threads,
                       Columns& Y) {
    multiply_operator_here(op, X, threads, Y);
}

}  // namespace formfactor::distributed
