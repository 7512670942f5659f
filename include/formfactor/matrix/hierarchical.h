#pragma once
/// A hierarchical (H-matrix) form-factor operator for scenes in which everything sees everything
/// (closed rooms, furnaces, convex cavities): F is never formed. See docs/hierarchical.md. This
/// header holds its storage and products; build_hierarchical() (methods/hierarchical_build.h)
/// computes its blocks.
///
/// A cluster tree over the patches (binary, split at the median of the longest axis of the
/// centroids, leaves of at most leaf_size patches) partitions the unordered cluster pairs into
///  - zero blocks: one cluster lies in the plane of the other (or behind it), which is then
///    planar: every entry is 0 exactly (the patches of one wall of a room);
///  - low-rank blocks: well-separated pairs (max diameter ≤ eta · distance of the bounding
///    spheres), F_PQ ≈ U Vᵀ by adaptive cross approximation with partial pivoting (ACA; Bebendorf
///    2000) to the relative Frobenius error `tolerance`, its entries by a Gauss rule whose
///    a-priori error bound is below tolerance/10 of the kernel's size there;
///  - dense blocks: the leaf pairs left, exact entries (the double contour integral).
/// Only F_PQ of each unordered pair is stored: F_QP = diag(1/A_Q) F_PQᵀ diag(A_P) (reciprocity,
/// which exact form factors satisfy), so the operator is reciprocal by construction.
///
/// Why ACA and not hierarchical-radiosity links: a link is a rank-1 block with the kernel's
/// value at one point pair, whose error falls only as (size/distance)²; ACA finds the rank a
/// block needs for a stated relative error, so the error target is a parameter, not a property
/// of the refinement oracle, and it falls when the target is tightened.
///
/// Obstruction: blocks are exact only without blockers. A scene in which a surface can block a
/// segment between two others (may_obstruct(), scene/obstruction.h) is refused with an Error naming
/// the alternatives (dense or sparse storage); visibility in blocks is left for later.
///
/// Products are deterministic: the blocks are summed in a fixed order of fixed chunks, so y = F x
/// is bit-identical for any thread count. The chunks are also what MPI ranks share out
/// (distributed/distributed.h): an operator may hold the blocks of a run of chunks only (a
/// part), whose partial products are added to the running sums of the chunks before it, so that
/// the ranks together sum every product exactly as one process does.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// What the build made and what it cost.
struct HierarchicalStats {
    std::size_t patches = 0;
    std::size_t clusters = 0, leaves = 0;
    std::size_t zero_blocks = 0, dense_blocks = 0, low_rank_blocks = 0;
    /// Low-rank blocks that ACA could not compress below their dense size (stored dense).
    std::size_t low_rank_fallbacks = 0;
    std::size_t dense_values = 0;     ///< doubles in dense blocks
    std::size_t low_rank_values = 0;  ///< doubles in U and V of the low-rank blocks
    std::size_t max_rank = 0;
    double mean_rank = 0.0;
    /// Patch pairs (unordered) covered by each kind of block.
    double pairs_zero = 0, pairs_dense = 0, pairs_low_rank = 0;
    std::size_t entries_computed = 0;  ///< F_ij evaluated during the build
    std::size_t bytes = 0;             ///< memory the operator holds
    double seconds = 0.0;              ///< wall time of the build
    double tolerance = 0.0, eta = 0.0;
    std::size_t leaf_size = 0;
};

/// The operator. Patch order is the scene's.
class HierarchicalFormFactors {
  public:
    /// One stored block of the partition, on patch ranges of the cluster order: rows
    /// [p, p + m), columns [q, q + n) (p ≤ q; p = q only for a dense diagonal block, which holds
    /// all of F_PP). Dense: F_PQ row-major in `u` (rank 0). Low-rank: F_PQ = U Vᵀ, U m × rank
    /// and V n × rank column-major in `u` and `v`.
    struct Block {
        std::uint32_t p = 0, m = 0, q = 0, n = 0;
        std::uint32_t rank = 0;
        std::vector<double> u, v;
    };
    /// Products are summed in this many fixed chunks of blocks (deterministic for any thread
    /// count).
    static constexpr std::size_t kChunks = 16;

    /// The operator of the given blocks (build_hierarchical() in methods/hierarchical_build.h
    /// makes them): areas in scene order, order[k] the patch at cluster position k, blocks on
    /// cluster-order ranges; the stats as the build counted them (bytes is filled in here).
    HierarchicalFormFactors(std::vector<double> areas, std::vector<std::uint32_t> order,
                            std::vector<Block> blocks, HierarchicalStats stats);

    /// The work of a block in a product (what the chunks even out): its stored values and its
    /// rows and columns.
    static double block_work(const Block& b) { return double(b.u.size() + b.v.size() + b.m + b.n); }
    /// Where each chunk starts in the list of blocks whose works are `work` (in block order),
    /// and the end: at most kChunks + 1 ascending indices from 0 to work.size(), each chunk
    /// about 1/kChunks of the total. The whole operator's chunks.
    static std::vector<std::size_t> chunk_bounds(const std::vector<double>& work);

    /// One rank's part of an operator spread over ranks: `blocks` are the blocks of chunks
    /// [first_chunk, first_chunk + bounds.size() − 1) of the whole operator (chunk_bounds() of
    /// every block's work), `bounds` where each of them starts in `blocks` (from 0 to
    /// blocks.size()); stats are the whole operator's (bytes is this part's). A part computes
    /// partial products only (partial_products()); multiply() and the calls built on it need
    /// the whole operator (Error otherwise).
    static HierarchicalFormFactors part(std::vector<double> areas, std::vector<std::uint32_t> order,
                                        std::vector<Block> blocks, std::vector<std::size_t> bounds,
                                        std::size_t first_chunk, HierarchicalStats stats);

    std::size_t size() const { return areas_.size(); }
    const std::vector<double>& areas() const { return areas_; }
    const HierarchicalStats& stats() const { return stats_; }
    /// True when this operator holds every block (not a part()).
    bool whole() const { return whole_; }
    /// The blocks this operator holds, and the chunks: [first_chunk(), first_chunk() + chunks()).
    std::size_t blocks() const { return blocks_.size(); }
    std::size_t first_chunk() const { return first_chunk_; }
    std::size_t chunks() const { return chunk_begin_.size() - 1; }

    /// Y = F X for an n × k column-major X (one column per channel); Y is resized.
    void multiply(const Eigen::MatrixXd& X, Eigen::MatrixXd& Y, int threads = 0) const;
    /// Σ_j F_ij per row (F·1).
    std::vector<double> row_sums(int threads = 0) const;
    /// The operator as a dense matrix (N² doubles: for tests and small scenes).
    DenseMatrix to_dense(int threads = 0) const;
    /// Per-group factors F_GH = Σ_{i∈G} A_i Σ_{j∈H} F_ij / A_G (groups: a patch's group index,
    /// 0 ≤ g < groups), from `groups` products with indicator vectors: cost groups × product.
    DenseMatrix per_group(const std::vector<int>& group_of_patch, std::size_t groups,
                          int threads = 0) const;
    /// Y = F X for an n × k X (an operator's multiply(), or its product over the ranks).
    using Product = std::function<void(const Eigen::MatrixXd& X, Eigen::MatrixXd& Y)>;
    /// per_group() of an operator held elsewhere (spread over ranks): one call of `product`
    /// with every group's indicator column at once; `areas` are A_i in scene order.
    static DenseMatrix per_group(const std::vector<double>& areas,
                                 const std::vector<int>& group_of_patch, std::size_t groups,
                                 const Product& product);
    /// to_dense() of an operator of `patches` patches held elsewhere (spread over ranks):
    /// `product` of the identity's columns, a few at a time, as to_dense() makes them (the same
    /// bits when `product` is multiply()'s).
    static DenseMatrix to_dense(std::size_t patches, const Product& product);

    /// A product in pieces, as multiply() does it and ranks share it: the partial products
    /// of this operator's chunks (in cluster order: y of the blocks F_PQ, z of their
    /// transposed halves before the division by the areas), then add_partials() adds them in
    /// chunk order to the running sums of the chunks before (zero before the first chunk), then
    /// finish_product() makes Y of the sums of every chunk.
    struct Partials {
        std::vector<Eigen::MatrixXd> y, z;  ///< one per chunk, n × k
    };
    Partials partial_products(const Eigen::MatrixXd& X, int threads = 0) const;
    /// Yt += y[c], Zt += z[c] for c in order (Yt, Zt n × k).
    static void add_partials(const Partials& p, Eigen::MatrixXd& Yt, Eigen::MatrixXd& Zt);
    /// Y (scene order) of the sums Yt, Zt of every chunk.
    void finish_product(const Eigen::MatrixXd& Yt, const Eigen::MatrixXd& Zt,
                        Eigen::MatrixXd& Y) const;

  private:
    std::vector<double> areas_;         ///< scene order
    std::vector<std::uint32_t> order_;  ///< cluster order → patch index
    std::vector<double> tree_areas_;    ///< areas in cluster order
    std::vector<Block> blocks_;
    std::vector<std::size_t> chunk_begin_;  ///< blocks [chunk_begin_[c], chunk_begin_[c + 1])
    std::size_t first_chunk_ = 0;           ///< of the whole operator's chunks
    bool whole_ = true;
    HierarchicalStats stats_;

    HierarchicalFormFactors() = default;
    void set_areas_and_bytes();
};

}  // namespace formfactor
