#pragma once
/// Building the hierarchical form-factor operator (matrix/hierarchical.h): the cluster tree, the
/// partition into zero, low-rank and dense blocks, and their entries by the analytic kernels.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "formfactor/matrix/hierarchical.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

class ProgressSink;

/// How the operator is built.
struct HierarchicalOptions {
    /// Error target: relative Frobenius error of each compressed block (the entries of the
    /// compressed blocks are computed to a tenth of it). Tighter targets cost more ranks.
    double tolerance = 1e-6;
    /// Admissibility: a cluster pair is compressed when 2·max(r_P, r_Q) ≤ eta · (|c_P − c_Q| −
    /// r_P − r_Q) (bounding spheres).
    double eta = 1.5;
    /// Patches per leaf cluster at most.
    std::size_t leaf_size = 32;
    /// Threads (0 = all cores).
    int threads = 0;
    /// Receives the progress of the build (blocks done), or none.
    ProgressSink* progress = nullptr;
};

/// True when build_hierarchical() accepts the scene's geometry: no surface can
/// block the view between two others (within 1e-6 of the scene's size; surfaces, or patches when
/// the scene has none). What `solve --storage auto` asks before it picks the operator.
bool hierarchical_accepts(const Scene& scene);

/// The partition of a scene's operator before any entry is computed: what MPI ranks share out
/// (distributed/distributed.h), each computing some of the blocks. build_hierarchical() is a
/// plan whose every block is computed. Every block is computed alone (ACA's random samples are
/// seeded by the block), so a block is bit for bit the same whoever computes it.
class HierarchicalPlan {
  public:
    /// The checks of build_hierarchical(), the cluster tree and the partition. Throws as
    /// build_hierarchical() does, memory apart: the caller checks what it will hold with
    /// check_memory() (one process the whole operator, an MPI rank its share). `scene` must
    /// outlive the plan.
    HierarchicalPlan(const Scene& scene, const HierarchicalOptions& options);
    ~HierarchicalPlan();
    HierarchicalPlan(HierarchicalPlan&&) noexcept;
    HierarchicalPlan& operator=(HierarchicalPlan&&) noexcept;

    /// The stored blocks (dense and low-rank; zero blocks are not stored), in the operator's
    /// order.
    std::size_t blocks() const;
    /// An estimate of block k's cost to compute, in far-field entries (an entry of a dense
    /// block, mostly exact contour integrals, counts as several).
    double estimated_cost(std::size_t k) const;
    /// Blocks `which` (indices of stored blocks), computed in parallel over options.threads
    /// (largest first); the entries computed and the low-rank blocks stored dense are added to
    /// counts.entries_computed and counts.low_rank_fallbacks. Throws Cancelled when the
    /// current cancellation is requested.
    std::vector<HierarchicalFormFactors::Block> compute(const std::vector<std::size_t>& which,
                                                        HierarchicalStats& counts) const;
    /// What one of `ranks` processes that computes blocks `built` (indices of stored blocks)
    /// holds at its peak, estimated before any entry is computed (dense blocks exactly,
    /// compressed blocks at rank ~10): the per-patch tables and the cluster tree, which every
    /// rank holds whole, and with one process every block; with more ranks the blocks it
    /// computes (kept until they have moved to the ranks that hold them) and 1/ranks of all the
    /// blocks (its run of chunks, about 1/ranks of the operator).
    MemoryEstimate estimate_memory(const std::vector<std::size_t>& built, std::size_t ranks) const;
    /// Throws ResourceError when estimate_memory(built, ranks).total() exceeds `available`
    /// bytes: what it needs, what is available and what to do instead (with more than one rank,
    /// the whole operator's estimate too). No check when available ≤ 0 (unknown).
    void check_memory(const std::vector<std::size_t>& built, std::size_t ranks,
                      double available) const;
    /// What the partition knows of the operator: the counts of blocks and pairs, clusters and
    /// options (no values, ranks, entries or seconds yet).
    const HierarchicalStats& stats() const;
    /// Areas in scene order; order()[k] is the patch at cluster position k.
    std::vector<double> areas() const;
    const std::vector<std::uint32_t>& order() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Counts the values and ranks of the blocks (rank and stored values of each, in any order)
/// into stats: dense_values, low_rank_values, max_rank, mean_rank.
void count_block_values(const std::vector<std::uint32_t>& ranks,
                        const std::vector<std::size_t>& values, HierarchicalStats& stats);

/// Throws the OptionError of build_hierarchical() for a bad tolerance, eta or leaf_size (before
/// any work: what a build over ranks checks before the ranks start).
void check_hierarchical_options(const HierarchicalOptions& options);

/// Builds the operator of the scene's patches. Throws OptionError for bad options, Error for a
/// scene with obstructions (see matrix/hierarchical.h), ResourceError when the estimated memory
/// does not fit.
HierarchicalFormFactors build_hierarchical(const Scene& scene, const HierarchicalOptions& options);

}  // namespace formfactor
