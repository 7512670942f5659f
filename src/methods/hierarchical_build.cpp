#include "formfactor/methods/hierarchical_build.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/scene/obstruction.h"
#include "kernels/analytic_internal.h"

namespace formfactor {

namespace {

constexpr int kMaxOwnOrder = 4;               // rules kept per patch for the far entries
constexpr std::uint32_t kEstimatedRank = 10;  // for the memory estimate before the build
// Vertices within 1e-6 of the scene's size of a plane count as in it (the planarity tolerance of
// the scene readers): a jittered mesh of a convex room is still a convex room, and what it could
// hide lies in a sliver that thin.
constexpr double kNearlyInPlane = 1e-6;  // relative to the scene's diagonal

// A patch in cluster order: what the entries need.
struct PatchData {
    const Polygon* polygon = nullptr;
    Vec3 c, n;
    double area = 0, radius = 0;
    std::array<PolygonRule, kMaxOwnOrder> rules;  // orders 1..kMaxOwnOrder
};

struct Node {
    std::uint32_t first = 0, count = 0;
    int left = -1, right = -1;
    Vec3 center;
    double radius = 0;
    Bounds3 box;  // of the vertices
    bool planar = false;
    Plane plane;
    bool leaf() const { return left < 0; }
};

enum class Kind { zero, dense, low_rank };
struct Spec {
    int a, b;  // nodes, a's range before b's (or a == b)
    Kind kind;
};

class Builder {
  public:
    Builder(const Scene& scene, const HierarchicalOptions& o) : scene_(scene), o_(o) {}

    std::vector<std::uint32_t> order;
    std::vector<PatchData> pd;
    std::vector<Node> nodes;
    std::vector<Spec> specs;
    double eps = 0;

    void build_tree() {
        const std::size_t n = scene_.patches.size();
        order.resize(n);
        std::iota(order.begin(), order.end(), 0u);
        Bounds3 all;
        for (const Patch& p : scene_.patches)
            for (const Vec3& v : p.polygon.vertices) all.extend(v);
        const double diag = std::max(all.diagonal().norm(), 1e-300);
        eps = 1e-9 * diag;
        // Plane groups: patches in one plane with one orientation (a wall of a room).
        std::map<std::array<long long, 4>, int> key_to_group;
        group_.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            const Patch& p = scene_.patches[i];
            const std::array<long long, 4> key = {
                std::llround(p.normal.x() * 1e8), std::llround(p.normal.y() * 1e8),
                std::llround(p.normal.z() * 1e8),
                std::llround(p.normal.dot(p.centroid) / diag * 1e8)};
            group_[i] =
                key_to_group.emplace(key, static_cast<int>(key_to_group.size())).first->second;
        }
        nodes.reserve(2 * n / std::max<std::size_t>(o_.leaf_size, 1) + 2);
        split(0, static_cast<std::uint32_t>(n));
        pd.resize(n);
        parallel_for(n, o_.threads, [&](std::size_t k) {
            const Patch& p = scene_.patches[order[k]];
            PatchData& d = pd[k];
            d.polygon = &p.polygon;
            d.c = p.centroid;
            d.n = p.normal;
            d.area = p.area;
            for (const Vec3& v : p.polygon.vertices)
                d.radius = std::max(d.radius, (v - d.c).norm());
            for (int r = 0; r < kMaxOwnOrder; ++r) d.rules[r] = polygon_rule(p.polygon, r + 1);
        });
    }

    void partition(int a, int b) {
        const Node& P = nodes[static_cast<std::size_t>(a)];
        const Node& Q = nodes[static_cast<std::size_t>(b)];
        if (a == b) {
            if (P.planar) {
                specs.push_back({a, b, Kind::zero});
            } else if (P.leaf()) {
                specs.push_back({a, b, Kind::dense});
            } else {
                partition(P.left, P.left);
                partition(P.left, P.right);
                partition(P.right, P.right);
            }
            return;
        }
        if (behind(P, Q) || behind(Q, P)) {
            specs.push_back({a, b, Kind::zero});
            return;
        }
        const double dist = (P.center - Q.center).norm() - P.radius - Q.radius;
        if (dist > 0.0 && 2.0 * std::max(P.radius, Q.radius) <= o_.eta * dist && facing(P, Q) &&
            facing(Q, P)) {
            specs.push_back({a, b, Kind::low_rank});
            return;
        }
        if (P.leaf() && Q.leaf()) {
            specs.push_back({a, b, Kind::dense});
            return;
        }
        // Split the larger cluster (keeping a's range before b's).
        if (Q.leaf() || (!P.leaf() && P.radius >= Q.radius)) {
            const int l = P.left, r = P.right;
            partition(l, b);
            partition(r, b);
        } else {
            const int l = Q.left, r = Q.right;
            partition(a, l);
            partition(a, r);
        }
    }

    // F_ij for patches i, j in cluster order.
    double entry(std::size_t i, std::size_t j) const {
        if (i == j) return 0.0;
        const PatchData& A = pd[i];
        const PatchData& B = pd[j];
        const Vec3 r = B.c - A.c;
        const double d2 = r.squaredNorm();
        const double d = std::sqrt(d2);
        // Separated, and each patch in the closed front half-space of the other (no clipping):
        // the Gauss rule of the smallest order whose a-priori bound (far_field_error_bound) is
        // below a tenth of the error target relative to the kernel's size there.
        const double dmin = d - A.radius - B.radius;
        if (dmin > 0.0 && in_front(B, A) && in_front(A, B)) {
            const double pref = std::max(A.area, B.area) * kInvPi / (dmin * dmin);
            const double target = 0.1 * o_.tolerance * B.area * kInvPi / d2;
            const double qa = A.radius / (d - B.radius), qb = B.radius / (d - A.radius);
            const double ia = qa / (1.0 + std::sqrt(1.0 - qa * qa));
            const double ib = qb / (1.0 + std::sqrt(1.0 - qb * qb));
            const double ra = ia * ia, rb = ib * ib;
            double ga = detail::kGaussConstantPublic * pref * ra;
            double gb = detail::kGaussConstantPublic * pref * rb;
            for (int k = 1; k <= kMaxOwnOrder; ++k) {
                if (ga + gb <= target) return quadrature(A, B, k);
                ga *= ra;
                gb *= rb;
            }
        }
        return polygon_to_polygon(*A.polygon, *B.polygon);
    }

    const HierarchicalOptions& options() const { return o_; }

  private:
    const Scene& scene_;
    const HierarchicalOptions& o_;
    std::vector<int> group_;  // plane group of each patch (scene order)

    // True when every vertex of `b` is on or in front of the plane of `a`.
    bool in_front(const PatchData& b, const PatchData& a) const {
        if (a.n.dot(b.c - a.c) > b.radius) return true;
        for (const Vec3& v : b.polygon->vertices)
            if (a.n.dot(v - a.c) < -eps) return false;
        return true;
    }

    static double quadrature(const PatchData& A, const PatchData& B, int order) {
        const PolygonRule& ra = A.rules[static_cast<std::size_t>(order - 1)];
        const PolygonRule& rb = B.rules[static_cast<std::size_t>(order - 1)];
        double sum = 0.0;
        for (std::size_t p = 0; p < ra.points.size(); ++p) {
            double s = 0.0;
            for (std::size_t q = 0; q < rb.points.size(); ++q) {
                const Vec3 r = rb.points[q] - ra.points[p];
                const double r2 = r.squaredNorm();
                s += rb.weights[q] * A.n.dot(r) * (-B.n.dot(r)) / (r2 * r2);
            }
            sum += ra.weights[p] * s;
        }
        return sum * kInvPi / A.area;
    }

    // True when every vertex of Q is in P's plane or behind it and P is planar: F_PQ = F_QP = 0.
    bool behind(const Node& P, const Node& Q) const {
        if (!P.planar) return false;
        for (int c = 0; c < 8; ++c) {
            const Vec3 v((c & 1) ? Q.box.hi.x() : Q.box.lo.x(),
                         (c & 2) ? Q.box.hi.y() : Q.box.lo.y(),
                         (c & 4) ? Q.box.hi.z() : Q.box.lo.z());
            if (P.plane.signed_distance(v) > eps) return false;
        }
        return true;
    }

    // True when the kernel is smooth on the block, which ACA needs: no patch of Q is cut by the
    // plane of a patch of P or lies in it (such entries are 0 next to positive ones, and ACA
    // misses a zero/non-zero pattern it does not sample). Q's bounding box must be in front of
    // every plane of P's patches; touching one is allowed only for a planar Q (one wall
    // touching another along an edge: cos θ vanishes there linearly, without a kink), since a
    // coplanar planar Q is a zero block already.
    bool facing(const Node& P, const Node& Q) const {
        for (std::uint32_t k = P.first; k < P.first + P.count; ++k) {
            const Patch& p = scene_.patches[order[k]];
            const double d = p.normal.dot(p.centroid);
            double lo = std::numeric_limits<double>::infinity();
            for (int c = 0; c < 8; ++c) {
                const Vec3 v((c & 1) ? Q.box.hi.x() : Q.box.lo.x(),
                             (c & 2) ? Q.box.hi.y() : Q.box.lo.y(),
                             (c & 4) ? Q.box.hi.z() : Q.box.lo.z());
                lo = std::min(lo, p.normal.dot(v) - d);
            }
            if (lo < -eps || (lo <= eps && !Q.planar)) return false;
        }
        return true;
    }

    int split(std::uint32_t first, std::uint32_t count) {
        const int id = static_cast<int>(nodes.size());
        nodes.emplace_back();
        {
            Node& nd = nodes.back();
            nd.first = first;
            nd.count = count;
            for (std::uint32_t k = first; k < first + count; ++k)
                for (const Vec3& v : scene_.patches[order[k]].polygon.vertices) nd.box.extend(v);
            nd.center = 0.5 * (nd.box.lo + nd.box.hi);
            for (std::uint32_t k = first; k < first + count; ++k)
                for (const Vec3& v : scene_.patches[order[k]].polygon.vertices)
                    nd.radius = std::max(nd.radius, (v - nd.center).norm());
            const Patch& p0 = scene_.patches[order[first]];
            nd.plane = {p0.normal, p0.normal.dot(p0.centroid)};
            nd.planar = true;
            for (std::uint32_t k = first; k < first + count && nd.planar; ++k) {
                const Patch& p = scene_.patches[order[k]];
                if (p.normal.dot(p0.normal) < 1.0 - 1e-12) nd.planar = false;
                for (const Vec3& v : p.polygon.vertices)
                    if (std::abs(nd.plane.signed_distance(v)) > eps) nd.planar = false;
            }
        }
        if (count <= o_.leaf_size) return id;
        Bounds3 cb;
        for (std::uint32_t k = first; k < first + count; ++k)
            cb.extend(scene_.patches[order[k]].centroid);
        int axis = 0;
        const Vec3 ext = cb.diagonal();
        if (ext.y() > ext[axis]) axis = 1;
        if (ext.z() > ext[axis]) axis = 2;
        std::uint32_t half = count / 2;
        // Several plane groups of which one has a leaf's worth of patches: split between
        // groups (keeping each whole), so that clusters below are planar (zero blocks within a
        // wall, smooth blocks between walls). Groups in the order of their centroids.
        std::map<int, std::pair<std::uint32_t, double>> in_range;  // group → (count, Σ coord)
        for (std::uint32_t k = first; k < first + count; ++k) {
            auto& g = in_range[group_[order[k]]];
            ++g.first;
            g.second += scene_.patches[order[k]].centroid[axis];
        }
        std::uint32_t largest = 0;
        for (const auto& [g, cs] : in_range) largest = std::max(largest, cs.first);
        if (in_range.size() > 1 && largest >= o_.leaf_size) {
            std::vector<std::pair<double, int>> groups;
            for (const auto& [g, cs] : in_range) groups.emplace_back(cs.second / cs.first, g);
            std::sort(groups.begin(), groups.end());
            std::map<int, bool> left;
            std::uint32_t acc = 0;
            for (std::size_t k = 0; k < groups.size(); ++k) {
                const std::uint32_t c = in_range[groups[k].second].first;
                const bool take = k == 0 || (k + 1 < groups.size() && acc + c / 2 <= count / 2);
                left[groups[k].second] = take;
                if (take) acc += c;
            }
            const auto mid =
                std::stable_partition(order.begin() + first, order.begin() + first + count,
                                      [&](std::uint32_t i) { return left[group_[i]]; });
            half = static_cast<std::uint32_t>(mid - (order.begin() + first));
            const int l = split(first, half);
            const int r = split(first + half, count - half);
            nodes[static_cast<std::size_t>(id)].left = l;
            nodes[static_cast<std::size_t>(id)].right = r;
            return id;
        }
        auto key = [&](std::uint32_t i) {
            const Vec3& c = scene_.patches[i].centroid;
            return std::make_tuple(c[axis], c[(axis + 1) % 3], c[(axis + 2) % 3], i);
        };
        std::nth_element(order.begin() + first, order.begin() + first + half,
                         order.begin() + first + count,
                         [&](std::uint32_t x, std::uint32_t y) { return key(x) < key(y); });
        const int l = split(first, half);
        const int r = split(first + half, count - half);
        nodes[static_cast<std::size_t>(id)].left = l;
        nodes[static_cast<std::size_t>(id)].right = r;
        return id;
    }
};

using Block = HierarchicalFormFactors::Block;

void fill_dense(const Builder& b, Block& blk, std::size_t& computed) {
    blk.rank = 0;
    blk.u.assign(static_cast<std::size_t>(blk.m) * blk.n, 0.0);
    blk.v.clear();
    for (std::uint32_t i = 0; i < blk.m; ++i)
        for (std::uint32_t j = 0; j < blk.n; ++j)
            blk.u[static_cast<std::size_t>(i) * blk.n + j] = b.entry(blk.p + i, blk.q + j);
    computed += static_cast<std::size_t>(blk.m) * blk.n;
}

// One block's adaptive cross approximation (fill_low_rank()): the crosses so far (U and V
// column-major, a column of each per cross), the rows and columns used as pivots, and the
// running ‖U Vᵀ‖_F².
class CrossApproximation {
  public:
    CrossApproximation(const Builder& b, const Block& blk, std::size_t& computed)
        : b_(b),
          p_(blk.p),
          q_(blk.q),
          m_(blk.m),
          n_(blk.n),
          computed_(computed),
          row_used_(m_, 0),
          col_used_(n_, 0),
          row_(n_),
          col_(m_),
          rng_(0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(blk.p) << 32) ^ blk.q) {}

    std::uint32_t rank() const { return rank_; }

    // Row i of the residual A − U Vᵀ, i then used; its largest unused column (n when none is
    // non-zero).
    std::uint32_t residual_row(std::uint32_t i) {
        for (std::uint32_t j = 0; j < n_; ++j) row_[j] = b_.entry(p_ + i, q_ + j);
        computed_ += n_;
        for (std::uint32_t l = 0; l < rank_; ++l) {
            const double ui = U_[static_cast<std::size_t>(l) * m_ + i];
            const double* vl = V_.data() + static_cast<std::size_t>(l) * n_;
            for (std::uint32_t j = 0; j < n_; ++j) row_[j] -= ui * vl[j];
        }
        row_used_[i] = 1;
        std::uint32_t j_star = n_;
        double best = 0.0;
        for (std::uint32_t j = 0; j < n_; ++j)
            if (!col_used_[j] && std::abs(row_[j]) > best) {
                best = std::abs(row_[j]);
                j_star = j;
            }
        return j_star;
    }

    // The cross through column j of the last residual row: the residual's column j and the row
    // divided by its pivot, appended to U and V; true when the cross is within tol of the
    // approximation (ACA's stopping rule, with ‖U Vᵀ‖_F² updated by the cross's products).
    bool add_cross(std::uint32_t j, double tol) {
        const double pivot = row_[j];
        for (std::uint32_t i = 0; i < m_; ++i) col_[i] = b_.entry(p_ + i, q_ + j);
        computed_ += m_;
        for (std::uint32_t l = 0; l < rank_; ++l) {
            const double vj = V_[static_cast<std::size_t>(l) * n_ + j];
            const double* ul = U_.data() + static_cast<std::size_t>(l) * m_;
            for (std::uint32_t i = 0; i < m_; ++i) col_[i] -= ul[i] * vj;
        }
        col_used_[j] = 1;
        double uu = 0.0, vv = 0.0, cross = 0.0;
        for (std::uint32_t i = 0; i < m_; ++i) uu += col_[i] * col_[i];
        for (std::uint32_t k = 0; k < n_; ++k) {
            row_[k] /= pivot;
            vv += row_[k] * row_[k];
        }
        for (std::uint32_t l = 0; l < rank_; ++l) {
            double a = 0.0, c = 0.0;
            const double* ul = U_.data() + static_cast<std::size_t>(l) * m_;
            const double* vl = V_.data() + static_cast<std::size_t>(l) * n_;
            for (std::uint32_t i = 0; i < m_; ++i) a += ul[i] * col_[i];
            for (std::uint32_t k = 0; k < n_; ++k) c += vl[k] * row_[k];
            cross += a * c;
        }
        norm2_ += 2.0 * cross + uu * vv;
        U_.insert(U_.end(), col_.begin(), col_.end());
        V_.insert(V_.end(), row_.begin(), row_.end());
        ++rank_;
        return std::sqrt(uu * vv) <= tol * std::sqrt(std::max(norm2_, 0.0));
    }

    // The sampled check after ACA's rule is met (it sees only the pivots' rows and columns): 16
    // entries at random, unless `checks` (of 8) are spent; the unused row of the sample whose
    // residual, scaled to the block, is furthest above the target, or m when none is.
    std::uint32_t sampled_row(double tol, int checks) {
        const double allowed = tol * std::sqrt(std::max(norm2_, 0.0) / (double(m_) * n_));
        double worst = 0.0;
        std::uint32_t next = m_;
        for (int s = 0; s < 16 && checks < 8; ++s) {
            const auto i = static_cast<std::uint32_t>(next_random() % m_);
            const auto j = static_cast<std::uint32_t>(next_random() % n_);
            const double r = std::abs(residual_at(i, j));
            ++computed_;
            if (r > allowed && r > worst && !row_used_[i]) {
                worst = r;
                next = i;
            }
        }
        return next;
    }

    // The unused row with the largest residual in the last cross's column (m when none).
    std::uint32_t pivot_row() const {
        std::uint32_t next = m_;
        double bu = -1.0;
        for (std::uint32_t i = 0; i < m_; ++i)
            if (!row_used_[i] && std::abs(col_[i]) > bu) {
                bu = std::abs(col_[i]);
                next = i;
            }
        return next;
    }

    // After row i had no residual: an unused row spread over the block from i, else the first
    // unused row (m when every row is used).
    std::uint32_t unused_row_after(std::uint32_t i) const {
        for (std::uint32_t k = 1; k <= m_; ++k) {
            const std::uint32_t r = (i + k * (m_ / 3 + 1)) % m_;
            if (!row_used_[r]) return r;
        }
        for (std::uint32_t r = 0; r < m_; ++r)
            if (!row_used_[r]) return r;
        return m_;
    }

    // The crosses into blk; a block with no residual anywhere sampled is kept as rank 1 of
    // zeros (rare; exact zeros are the zero blocks).
    void store(Block& blk) {
        blk.rank = rank_;
        if (rank_ == 0) {
            U_.assign(m_, 0.0);
            V_.assign(n_, 0.0);
            blk.rank = 1;
        }
        blk.u = std::move(U_);
        blk.v = std::move(V_);
    }

  private:
    std::uint64_t next_random() {
        rng_ ^= rng_ << 13;
        rng_ ^= rng_ >> 7;
        rng_ ^= rng_ << 17;
        return rng_;
    }
    double residual_at(std::uint32_t i, std::uint32_t j) const {
        double s = b_.entry(p_ + i, q_ + j);
        for (std::uint32_t l = 0; l < rank_; ++l)
            s -=
                U_[static_cast<std::size_t>(l) * m_ + i] * V_[static_cast<std::size_t>(l) * n_ + j];
        return s;
    }

    const Builder& b_;
    std::uint32_t p_, q_, m_, n_;
    std::size_t& computed_;
    std::vector<double> U_, V_;
    std::vector<char> row_used_, col_used_;
    std::vector<double> row_, col_;
    double norm2_ = 0.0;
    std::uint32_t rank_ = 0;
    std::uint64_t rng_;
};

// Adaptive cross approximation with partial pivoting to the relative Frobenius error tol, then
// a check of the residual at sampled entries (ACA's stopping rule only sees the pivots' rows and
// columns): a sample above the tolerance's share restarts the crosses at its row. Falls back to
// dense (false) when the rank stops paying.
bool fill_low_rank(const Builder& b, Block& blk, double tol, std::size_t& computed) {
    const std::uint32_t m = blk.m, n = blk.n;
    const auto max_rank =
        static_cast<std::uint32_t>((std::uint64_t{m} * n) / (std::uint64_t{m} + n));
    CrossApproximation aca(b, blk, computed);
    std::uint32_t i_star = 0, zero_rows = 0;
    int checks = 0;
    while (true) {
        if (aca.rank() >= max_rank) return false;
        const std::uint32_t j_star = aca.residual_row(i_star);
        bool converged = false;
        if (j_star == n) {
            // A row without residual: try another unused row (spread over the block); the
            // block is zero only when every row is.
            ++zero_rows;
            converged = zero_rows >= m;
        } else {
            zero_rows = 0;
            converged = aca.add_cross(j_star, tol);
        }
        std::uint32_t next = m;
        if (converged) {
            next = aca.sampled_row(tol, checks);
            if (next == m) break;
            ++checks;
            zero_rows = 0;
        } else if (j_star != n) {
            next = aca.pivot_row();
        } else {
            next = aca.unused_row_after(i_star);
        }
        if (next == m) break;  // every row used: exact
        i_star = next;
    }
    aca.store(blk);
    return true;
}

void check(const Scene& scene, const HierarchicalOptions& options) {
    check_hierarchical_options(options);
    const std::size_t n = scene.patches.size();
    if (n == 0) throw Error("hierarchical: the scene has no patches");
    if (n >= (1ull << 31)) throw Error("hierarchical: more than 2^31 patches");
    if (!hierarchical_accepts(scene))
        throw Error(
            "hierarchical storage: a surface of this scene can block the view between two others "
            "(obstructions); the hierarchical operator of this version is exact only without "
            "blockers (convex enclosures such as a closed room, furnace or cavity). Use `storage` "
            "dense or sparse");
}

// The blocks of the partition that are stored (dense and low-rank; zero blocks are not), counted
// into the stats, and each one's estimated bytes in `bytes` (dense exactly, compressed at rank
// kEstimatedRank).
std::vector<std::size_t> stored_blocks(const Builder& b, HierarchicalStats& st,
                                       std::vector<double>& bytes) {
    std::vector<std::size_t> stored;
    for (std::size_t s = 0; s < b.specs.size(); ++s) {
        const Spec& sp = b.specs[s];
        const Node& P = b.nodes[static_cast<std::size_t>(sp.a)];
        const Node& Q = b.nodes[static_cast<std::size_t>(sp.b)];
        const double pairs = sp.a == sp.b ? 0.5 * double(P.count) * (P.count - 1.0)
                                          : double(P.count) * double(Q.count);
        switch (sp.kind) {
            case Kind::zero:
                ++st.zero_blocks;
                st.pairs_zero += pairs;
                break;
            case Kind::dense:
                ++st.dense_blocks;
                st.pairs_dense += pairs;
                bytes.push_back(8.0 * P.count * Q.count);
                stored.push_back(s);
                break;
            case Kind::low_rank:
                ++st.low_rank_blocks;
                st.pairs_low_rank += pairs;
                bytes.push_back(8.0 * std::min<double>(double(P.count) * Q.count,
                                                       kEstimatedRank * (P.count + Q.count)));
                stored.push_back(s);
                break;
        }
    }
    return stored;
}

// Relative cost of an entry of a dense block (mostly exact contour integrals between
// neighbours) against one of a low-rank block (a Gauss rule): for sharing blocks out.
constexpr double kNearEntryCost = 4.0;

// The entries of blocks `which` (indices into `stored`), in parallel; per block the entries
// computed and whether a low-rank block fell back to dense.
std::vector<Block> compute_blocks(const Builder& b, const std::vector<std::size_t>& stored,
                                  const std::vector<std::size_t>& which,
                                  const HierarchicalOptions& options,
                                  std::vector<std::size_t>& computed,
                                  std::vector<char>& fell_back) {
    std::vector<Block> blocks(which.size());
    computed.assign(which.size(), 0);
    fell_back.assign(which.size(), 0);
    Progress progress("hierarchical operator", which.size(), options.progress);
    // Largest blocks first: the dynamic schedule then ends evenly.
    std::vector<std::size_t> by_size(which.size());
    std::iota(by_size.begin(), by_size.end(), 0);
    auto count_of = [&](std::size_t k) {
        const Spec& sp = b.specs[stored[which[k]]];
        return double(b.nodes[static_cast<std::size_t>(sp.a)].count) *
               double(b.nodes[static_cast<std::size_t>(sp.b)].count);
    };
    std::stable_sort(by_size.begin(), by_size.end(),
                     [&](std::size_t x, std::size_t y) { return count_of(x) > count_of(y); });
    // One block at a time from a shared counter: a static range of the largest blocks on one
    // thread would leave the others idle at the end.
    const CancellationFlag& cancel = current_cancellation();
    std::atomic<std::size_t> next{0};
    const auto workers = static_cast<std::size_t>(effective_threads(options.threads));
    parallel_for(workers, options.threads, [&](std::size_t) {
        for (std::size_t t; (t = next.fetch_add(1)) < which.size();) {
            cancel.throw_if_requested();
            const std::size_t k = by_size[t];
            const Spec& sp = b.specs[stored[which[k]]];
            const Node& P = b.nodes[static_cast<std::size_t>(sp.a)];
            const Node& Q = b.nodes[static_cast<std::size_t>(sp.b)];
            Block& blk = blocks[k];
            blk.p = P.first;
            blk.m = P.count;
            blk.q = Q.first;
            blk.n = Q.count;
            if (sp.kind == Kind::dense || !fill_low_rank(b, blk, options.tolerance, computed[k])) {
                if (sp.kind == Kind::low_rank) fell_back[k] = 1;
                fill_dense(b, blk, computed[k]);
            }
            progress.advance();
        }
    });
    progress.finish();
    return blocks;
}

// Entries computed and fallbacks of the computed blocks, into the stats.
void count_work(const std::vector<std::size_t>& computed, const std::vector<char>& fell_back,
                HierarchicalStats& st) {
    for (std::size_t k = 0; k < computed.size(); ++k) {
        st.entries_computed += computed[k];
        st.low_rank_fallbacks += fell_back[k];
    }
}

}  // namespace

void check_hierarchical_options(const HierarchicalOptions& options) {
    if (!(options.tolerance > 0.0 && options.tolerance <= 0.1))
        throw OptionError("tolerance", "the hierarchical error target must be in (0, 0.1]");
    if (!(options.eta > 0.0) || !std::isfinite(options.eta))
        throw OptionError("eta", "must be a positive number");
    if (options.leaf_size < 1 || options.leaf_size > 4096)
        throw OptionError("leaf_size", "must be between 1 and 4096");
}

bool hierarchical_accepts(const Scene& scene) { return !may_obstruct(scene, kNearlyInPlane); }

void count_block_values(const std::vector<std::uint32_t>& ranks,
                        const std::vector<std::size_t>& values, HierarchicalStats& st) {
    FF_ASSERT(ranks.size() == values.size());
    std::size_t rank_sum = 0, rank_blocks = 0;
    for (std::size_t k = 0; k < ranks.size(); ++k) {
        if (ranks[k] > 0) {
            st.low_rank_values += values[k];
            st.max_rank = std::max<std::size_t>(st.max_rank, ranks[k]);
            rank_sum += ranks[k];
            ++rank_blocks;
        } else {
            st.dense_values += values[k];
        }
    }
    st.mean_rank = rank_blocks ? double(rank_sum) / double(rank_blocks) : 0.0;
}

struct HierarchicalPlan::Impl {
    Impl(const Scene& s, const HierarchicalOptions& o) : scene(s), options(o), b(s, options) {}
    const Scene& scene;
    HierarchicalOptions options;
    Builder b;
    std::vector<std::size_t> stored;
    std::vector<double> stored_bytes;  // estimated, per stored block
    HierarchicalStats st;
};

HierarchicalPlan::HierarchicalPlan(const Scene& scene, const HierarchicalOptions& options) {
    check(scene, options);
    impl_ = std::make_unique<Impl>(scene, options);
    Builder& b = impl_->b;
    b.build_tree();
    b.partition(0, 0);
    HierarchicalStats& st = impl_->st;
    const std::size_t n = scene.patches.size();
    st.patches = n;
    st.clusters = b.nodes.size();
    for (const Node& nd : b.nodes) st.leaves += nd.leaf() ? 1 : 0;
    st.tolerance = options.tolerance;
    st.eta = options.eta;
    st.leaf_size = options.leaf_size;
    impl_->stored = stored_blocks(b, st, impl_->stored_bytes);
}

HierarchicalPlan::~HierarchicalPlan() = default;
HierarchicalPlan::HierarchicalPlan(HierarchicalPlan&&) noexcept = default;
HierarchicalPlan& HierarchicalPlan::operator=(HierarchicalPlan&&) noexcept = default;

std::size_t HierarchicalPlan::blocks() const { return impl_->stored.size(); }

double HierarchicalPlan::estimated_cost(std::size_t k) const {
    const Builder& b = impl_->b;
    const Spec& sp = b.specs[impl_->stored.at(k)];
    const double m = b.nodes[static_cast<std::size_t>(sp.a)].count;
    const double n = b.nodes[static_cast<std::size_t>(sp.b)].count;
    if (sp.kind == Kind::dense) return kNearEntryCost * m * n;
    // ACA: a row and a column per cross, and the sampled checks.
    return std::min(kNearEntryCost * m * n, (kEstimatedRank + 2.0) * (m + n) + 32.0);
}

std::vector<HierarchicalFormFactors::Block> HierarchicalPlan::compute(
    const std::vector<std::size_t>& which, HierarchicalStats& counts) const {
    for (std::size_t k : which)
        if (k >= impl_->stored.size()) throw Error("hierarchical: a block that is not stored");
    std::vector<std::size_t> computed;
    std::vector<char> fell_back;
    std::vector<Block> blocks =
        compute_blocks(impl_->b, impl_->stored, which, impl_->options, computed, fell_back);
    count_work(computed, fell_back, counts);
    return blocks;
}

MemoryEstimate HierarchicalPlan::estimate_memory(const std::vector<std::size_t>& built,
                                                 std::size_t ranks) const {
    const std::size_t n = impl_->scene.patches.size();
    double all = 0.0;
    for (double bytes : impl_->stored_bytes) all += bytes;
    MemoryEstimate e;
    e.add(fmt::format("tables and cluster tree of {} patches", format_count(double(n))),
          double(n) * (kBytesPerPatch + 8.0 * HierarchicalFormFactors::kChunks));
    if (ranks <= 1) {
        e.add(fmt::format("{} blocks", format_count(double(impl_->stored.size()))), all);
        return e;
    }
    double mine = 0.0;
    for (std::size_t k : built) mine += impl_->stored_bytes.at(k);
    e.add(fmt::format("{} blocks computed", format_count(double(built.size()))), mine);
    e.add(fmt::format("1/{} of all blocks held", ranks), all / double(ranks));
    return e;
}

void HierarchicalPlan::check_memory(const std::vector<std::size_t>& built, std::size_t ranks,
                                    double available) const {
    const MemoryEstimate mine = estimate_memory(built, ranks);
    const double need = mine.total();
    if (!(available > 0.0) || need <= available) return;
    const HierarchicalStats& st = impl_->st;
    const std::size_t n = impl_->scene.patches.size();
    if (ranks <= 1)
        throw ResourceError(fmt::format(
            "hierarchical operator of {} patches: needs about {:.1f} GB ({} dense blocks, {} "
            "compressed at rank ~{}), {:.1f} GB available; loosen the tolerance, use a coarser "
            "subdivision or a machine with more memory",
            n, need / 1e9, st.dense_blocks, st.low_rank_blocks, kEstimatedRank, available / 1e9));
    std::string parts;
    for (const MemoryEstimate::Item& item : mine.items)
        parts += (parts.empty() ? "" : ", ") + item.what + ": " + format_bytes(item.bytes);
    throw ResourceError(fmt::format(
        "hierarchical operator of {} patches over {} ranks: this rank needs about {} ({}; the "
        "whole operator {}), {} available; use more ranks, a coarser subdivision or machines "
        "with more memory",
        n, ranks, format_bytes(need), parts, format_bytes(estimate_memory({}, 1).total()),
        format_bytes(available)));
}

const HierarchicalStats& HierarchicalPlan::stats() const { return impl_->st; }

std::vector<double> HierarchicalPlan::areas() const {
    const std::size_t n = impl_->scene.patches.size();
    std::vector<double> areas(n);
    for (std::size_t i = 0; i < n; ++i) areas[i] = impl_->scene.patches[i].area;
    return areas;
}

const std::vector<std::uint32_t>& HierarchicalPlan::order() const { return impl_->b.order; }

HierarchicalFormFactors build_hierarchical(const Scene& scene, const HierarchicalOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    HierarchicalPlan plan(scene, options);
    HierarchicalStats st = plan.stats();
    std::vector<std::size_t> all(plan.blocks());
    std::iota(all.begin(), all.end(), 0);
    plan.check_memory(all, 1, available_memory());
    std::vector<Block> blocks = plan.compute(all, st);
    std::vector<std::uint32_t> ranks(blocks.size());
    std::vector<std::size_t> values(blocks.size());
    for (std::size_t k = 0; k < blocks.size(); ++k) {
        ranks[k] = blocks[k].rank;
        values[k] = blocks[k].u.size() + blocks[k].v.size();
    }
    count_block_values(ranks, values, st);
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return HierarchicalFormFactors(plan.areas(), plan.order(), std::move(blocks), std::move(st));
}

}  // namespace formfactor
