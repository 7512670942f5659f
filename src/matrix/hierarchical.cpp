#include "formfactor/matrix/hierarchical.h"

#include <fmt/format.h>

#include <algorithm>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"

namespace formfactor {

HierarchicalFormFactors::HierarchicalFormFactors(std::vector<double> areas,
                                                 std::vector<std::uint32_t> order,
                                                 std::vector<Block> blocks, HierarchicalStats stats)
    : areas_(std::move(areas)),
      order_(std::move(order)),
      blocks_(std::move(blocks)),
      stats_(std::move(stats)) {
    std::vector<double> work(blocks_.size());
    for (std::size_t k = 0; k < blocks_.size(); ++k) work[k] = block_work(blocks_[k]);
    chunk_begin_ = chunk_bounds(work);
    set_areas_and_bytes();
}

std::vector<std::size_t> HierarchicalFormFactors::chunk_bounds(const std::vector<double>& work) {
    // Chunks of about equal work, in block order (fixed for a scene and options).
    double total = 0.0;
    for (double w : work) total += w;
    std::vector<std::size_t> begin{0};
    double acc = 0.0;
    for (std::size_t k = 0; k < work.size(); ++k) {
        acc += work[k];
        if (acc >= total * double(begin.size()) / double(kChunks) && begin.size() < kChunks)
            begin.push_back(k + 1);
    }
    if (begin.back() != work.size()) begin.push_back(work.size());
    return begin;
}

HierarchicalFormFactors HierarchicalFormFactors::part(
    std::vector<double> areas, std::vector<std::uint32_t> order, std::vector<Block> blocks,
    std::vector<std::size_t> bounds, std::size_t first_chunk, HierarchicalStats stats) {
    FF_ASSERT(!bounds.empty() && bounds.front() == 0 && bounds.back() == blocks.size());
    HierarchicalFormFactors h;
    h.areas_ = std::move(areas);
    h.order_ = std::move(order);
    h.blocks_ = std::move(blocks);
    h.chunk_begin_ = std::move(bounds);
    h.first_chunk_ = first_chunk;
    h.whole_ = false;
    h.stats_ = std::move(stats);
    h.set_areas_and_bytes();
    std::size_t values = 0;
    for (const Block& b : h.blocks_) values += b.u.size() + b.v.size();
    h.stats_.bytes = 8 * values + h.blocks_.size() * sizeof(Block) +
                     h.size() * (2 * sizeof(double) + sizeof(std::uint32_t));
    return h;
}

void HierarchicalFormFactors::set_areas_and_bytes() {
    const std::size_t n = areas_.size();
    FF_ASSERT(order_.size() == n);
    tree_areas_.resize(n);
    for (std::size_t k = 0; k < n; ++k) tree_areas_[k] = areas_[order_[k]];
    stats_.bytes = 8 * (stats_.dense_values + stats_.low_rank_values) +
                   blocks_.size() * sizeof(Block) +
                   n * (2 * sizeof(double) + sizeof(std::uint32_t));
}

HierarchicalFormFactors::Partials HierarchicalFormFactors::partial_products(
    const Eigen::MatrixXd& X, int threads) const {
    const auto n = static_cast<Eigen::Index>(size());
    FF_ASSERT(X.rows() == n);
    const Eigen::Index k = X.cols();
    using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    // In cluster order: X, and A ∘ X for the transposed halves.
    Eigen::MatrixXd Xt(n, k), AXt(n, k);
    for (Eigen::Index t = 0; t < n; ++t) {
        Xt.row(t) = X.row(static_cast<Eigen::Index>(order_[static_cast<std::size_t>(t)]));
        AXt.row(t) = tree_areas_[static_cast<std::size_t>(t)] * Xt.row(t);
    }
    const std::size_t chunks = chunk_begin_.size() - 1;
    // Per chunk: Y (direct halves) and Z (transposed halves, divided by the areas at the end).
    Partials out;
    out.y.resize(chunks);
    out.z.resize(chunks);
    parallel_for(chunks, threads, [&](std::size_t c) {
        Eigen::MatrixXd& Yk = out.y[c];
        Eigen::MatrixXd& Zk = out.z[c];
        Yk.setZero(n, k);
        Zk.setZero(n, k);
        for (std::size_t bi = chunk_begin_[c]; bi < chunk_begin_[c + 1]; ++bi) {
            const Block& b = blocks_[bi];
            const auto p = static_cast<Eigen::Index>(b.p), m = static_cast<Eigen::Index>(b.m);
            const auto q = static_cast<Eigen::Index>(b.q), w = static_cast<Eigen::Index>(b.n);
            if (b.rank == 0) {
                const Eigen::Map<const RowMat> D(b.u.data(), m, w);
                Yk.middleRows(p, m).noalias() += D * Xt.middleRows(q, w);
                if (b.p != b.q)
                    Zk.middleRows(q, w).noalias() += D.transpose() * AXt.middleRows(p, m);
            } else {
                const auto r = static_cast<Eigen::Index>(b.rank);
                const Eigen::Map<const Eigen::MatrixXd> U(b.u.data(), m, r);
                const Eigen::Map<const Eigen::MatrixXd> V(b.v.data(), w, r);
                const Eigen::MatrixXd t = V.transpose() * Xt.middleRows(q, w);
                Yk.middleRows(p, m).noalias() += U * t;
                const Eigen::MatrixXd s = U.transpose() * AXt.middleRows(p, m);
                Zk.middleRows(q, w).noalias() += V * s;
            }
        }
    });
    return out;
}

void HierarchicalFormFactors::add_partials(const Partials& p, Eigen::MatrixXd& Yt,
                                           Eigen::MatrixXd& Zt) {
    for (std::size_t c = 0; c < p.y.size(); ++c) {
        Yt += p.y[c];
        Zt += p.z[c];
    }
}

void HierarchicalFormFactors::finish_product(const Eigen::MatrixXd& Yt, const Eigen::MatrixXd& Zt,
                                             Eigen::MatrixXd& Y) const {
    const auto n = static_cast<Eigen::Index>(size());
    FF_ASSERT(Yt.rows() == n && Zt.rows() == n && Yt.cols() == Zt.cols());
    Y.resize(n, Yt.cols());
    for (Eigen::Index t = 0; t < n; ++t)
        Y.row(static_cast<Eigen::Index>(order_[static_cast<std::size_t>(t)])) =
            Yt.row(t) + Zt.row(t) / tree_areas_[static_cast<std::size_t>(t)];
}

void HierarchicalFormFactors::multiply(const Eigen::MatrixXd& X, Eigen::MatrixXd& Y,
                                       int threads) const {
    if (!whole_)
        throw Error("hierarchical operator: a product needs every block; this is one rank's part");
    const auto n = static_cast<Eigen::Index>(size());
    const Partials p = partial_products(X, threads);
    Eigen::MatrixXd Yt = Eigen::MatrixXd::Zero(n, X.cols()),
                    Zt = Eigen::MatrixXd::Zero(n, X.cols());
    add_partials(p, Yt, Zt);
    finish_product(Yt, Zt, Y);
}

std::vector<double> HierarchicalFormFactors::row_sums(int threads) const {
    const auto n = static_cast<Eigen::Index>(size());
    Eigen::MatrixXd X = Eigen::MatrixXd::Ones(n, 1), Y;
    multiply(X, Y, threads);
    return std::vector<double>(Y.data(), Y.data() + n);
}

DenseMatrix HierarchicalFormFactors::to_dense(int threads) const {
    return to_dense(size(),
                    [&](const Eigen::MatrixXd& X, Eigen::MatrixXd& Y) { multiply(X, Y, threads); });
}

DenseMatrix HierarchicalFormFactors::to_dense(std::size_t patches, const Product& product) {
    const auto n = static_cast<Eigen::Index>(patches);
    DenseMatrix F(n, n);
    // Column blocks of the identity, a few at a time.
    constexpr Eigen::Index kCols = 64;
    for (Eigen::Index c0 = 0; c0 < n; c0 += kCols) {
        const Eigen::Index w = std::min(kCols, n - c0);
        Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, w), Y;
        for (Eigen::Index j = 0; j < w; ++j) X(c0 + j, j) = 1.0;
        product(X, Y);
        F.middleCols(c0, w) = Y;
    }
    return F;
}

DenseMatrix HierarchicalFormFactors::per_group(const std::vector<int>& group_of_patch,
                                               std::size_t groups, int threads) const {
    return per_group(
        areas_, group_of_patch, groups,
        [&](const Eigen::MatrixXd& X, Eigen::MatrixXd& Y) { multiply(X, Y, threads); });
}

DenseMatrix HierarchicalFormFactors::per_group(const std::vector<double>& areas,
                                               const std::vector<int>& group_of_patch,
                                               std::size_t groups, const Product& product) {
    const auto n = static_cast<Eigen::Index>(areas.size());
    if (group_of_patch.size() != areas.size())
        throw Error(fmt::format("per-group factors: {} group indices for {} patches",
                                group_of_patch.size(), areas.size()));
    const auto g = static_cast<Eigen::Index>(groups);
    Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, g), Y;
    for (Eigen::Index i = 0; i < n; ++i) {
        const int gi = group_of_patch[static_cast<std::size_t>(i)];
        if (gi < 0 || gi >= g)
            throw Error(fmt::format("per-group factors: patch {} in group {}", i, gi));
        X(i, gi) = 1.0;
    }
    product(X, Y);
    DenseMatrix out = DenseMatrix::Zero(g, g);
    std::vector<double> ag(static_cast<std::size_t>(g), 0.0);
    for (Eigen::Index i = 0; i < n; ++i) {
        const auto gi = static_cast<Eigen::Index>(group_of_patch[static_cast<std::size_t>(i)]);
        const double a = areas[static_cast<std::size_t>(i)];
        ag[static_cast<std::size_t>(gi)] += a;
        out.row(gi) += a * Y.row(i);
    }
    for (Eigen::Index r = 0; r < g; ++r)
        if (ag[static_cast<std::size_t>(r)] > 0.0) out.row(r) /= ag[static_cast<std::size_t>(r)];
    return out;
}

}  // namespace formfactor
