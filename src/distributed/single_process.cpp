// One rank (the library built without MPI): formfactor/distributed/distributed.h's calls are
// the pipeline's own.

#include "formfactor/distributed/distributed.h"

namespace formfactor::distributed {

bool built_with_mpi() { return false; }

Session::Session(int& argc, char**& argv) {
    (void)argc;
    (void)argv;
}
Session::~Session() = default;
int Session::rank() const { return 0; }
int Session::size() const { return 1; }
int rank() { return 0; }
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

}  // namespace formfactor::distributed
