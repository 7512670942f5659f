// The classification of the obstructed analytic method: the patches grouped by plane (nothing
// in one plane blocks a pair of that plane), each group a cluster tree whose nodes bound their
// patches by a convex hull; a group's tiles merged into convex blocker pieces; then for every
// pair of groups a recursion over node pairs whose shaft (Haines & Wallace 1994) is tested
// against the blocker pieces (shaft.cpp): hidden and visible node pairs end the recursion, the
// partly hidden patch pairs are kept with their candidate pieces for the integration. See
// docs/analytic.md, "Obstructed scenes".

#include "methods/analytic/classification.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"

namespace formfactor::detail {

int ClusterTree::build(const std::vector<TreeItem>& items, int first, int count) {
    const int id = static_cast<int>(nodes.size());
    nodes.push_back({});
    std::vector<Vec3> pts;
    Bounds3 cbox;
    for (int k = first; k < first + count; ++k) {
        const TreeItem& p = items[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])];
        for (const Vec3& v : p.polygon->vertices) pts.push_back(v);
        cbox.extend(p.centroid);
    }
    std::vector<Vec3> hull = detail::planar_convex_hull(pts, normal);
    if (hull.size() > static_cast<std::size_t>(detail::kMaxPieceVertices) || hull.size() < 3) {
        // Too many vertices for a shaft: the bounding rectangle in the plane (a superset).
        Vec3 u, v;
        orthonormal_basis(normal, u, v);
        double lo_u = 1e300, hi_u = -1e300, lo_v = 1e300, hi_v = -1e300;
        for (const Vec3& q : pts) {
            lo_u = std::min(lo_u, u.dot(q));
            hi_u = std::max(hi_u, u.dot(q));
            lo_v = std::min(lo_v, v.dot(q));
            hi_v = std::max(hi_v, v.dot(q));
        }
        const Vec3 o = normal * normal.dot(pts[0]);
        hull = {o + lo_u * u + lo_v * v, o + hi_u * u + lo_v * v, o + hi_u * u + hi_v * v,
                o + lo_u * u + hi_v * v};
    }
    Polygon hp;
    hp.vertices = hull;
    nodes[static_cast<std::size_t>(id)].area = area(hp);
    nodes[static_cast<std::size_t>(id)].hull = std::move(hull);
    nodes[static_cast<std::size_t>(id)].first = first;
    nodes[static_cast<std::size_t>(id)].count = count;
    if (count == 1) return id;
    int axis = 0;
    const Vec3 ext = cbox.diagonal();
    if (ext.y() > ext[axis]) axis = 1;
    if (ext.z() > ext[axis]) axis = 2;
    const int mid = first + count / 2;
    std::nth_element(order.begin() + first, order.begin() + mid, order.begin() + first + count,
                     [&](int a, int b) {
                         const double ca = items[static_cast<std::size_t>(a)].centroid[axis];
                         const double cb = items[static_cast<std::size_t>(b)].centroid[axis];
                         return ca < cb || (ca == cb && a < b);
                     });
    const int l = build(items, first, mid - first);
    const int r = build(items, mid, first + count - mid);
    nodes[static_cast<std::size_t>(id)].left = l;
    nodes[static_cast<std::size_t>(id)].right = r;
    return id;
}

namespace {

// When the polygons of node nd tile their convex hull (their areas add up to its area within
// 1e-9): that hull in `out`, as one convex blocker piece. Hull vertices within 1e-11 of the
// points' extent of the line through their neighbours are dropped first: the boundary vertices
// of a subdivided face are collinear only up to rounding, and a face split 12 × 12 would
// otherwise have a hull of more vertices than a piece may have (and block as many pieces).
bool tiled_hull(const ClusterTree& T, const ClusterTree::Node& nd,
                const std::vector<TreeItem>& items, double sum, Polygon& out) {
    std::vector<Vec3> pts;
    Bounds3 box;
    for (int k = nd.first; k < nd.first + nd.count; ++k)
        for (const Vec3& v : items[static_cast<std::size_t>(T.order[static_cast<std::size_t>(k)])]
                                 .polygon->vertices) {
            pts.push_back(v);
            box.extend(v);
        }
    std::vector<Vec3> hull = detail::planar_convex_hull(pts, T.normal);
    const double tol = 1e-11 * box.diagonal().norm();
    for (bool removed = true; removed && hull.size() > 3;) {
        removed = false;
        for (std::size_t k = 0; k < hull.size() && hull.size() > 3; ++k) {
            const Vec3& a = hull[(k + hull.size() - 1) % hull.size()];
            const Vec3& b = hull[(k + 1) % hull.size()];
            const Vec3 e = b - a;
            const double el = e.norm();
            if (el > 0.0 && e.cross(hull[k] - a).norm() <= tol * el) {
                hull.erase(hull.begin() + static_cast<std::ptrdiff_t>(k));
                removed = true;
            }
        }
    }
    if (hull.size() < 3 || hull.size() > static_cast<std::size_t>(detail::kMaxPieceVertices))
        return false;
    out.vertices = std::move(hull);
    const double a = area(out);
    return std::abs(sum - a) <= 1e-9 * a;
}

// The blocker pieces (into pool) that the tree finds in the shaft between the roots of the
// plane groups ta and tb; false when the groups face away from each other.
bool root_candidates(const std::vector<ClusterTree>& trees, const BlockerSet& blockers, double eps,
                     int ta, int tb, std::vector<int>& pool) {
    const ClusterTree& TA = trees[static_cast<std::size_t>(ta)];
    const ClusterTree& TB = trees[static_cast<std::size_t>(tb)];
    const auto& A = TA.nodes[0];
    const auto& B = TB.nodes[0];
    Shaft sh;
    sh.build(A.hull.data(), static_cast<int>(A.hull.size()), TA.normal, B.hull.data(),
             static_cast<int>(B.hull.size()), TB.normal, eps);
    if (sh.facing_away()) return false;
    blockers.query(sh, TA.blocker_id, TB.blocker_id, pool);
    return true;
}

// The partly hidden pairs below a node pair of at most this many patch pairs share its
// candidate list as their anchor (CandidateLists). On the urban array of 3,026 triangles, bytes
// a pair: 28.1 with a list each, 18.0 at 16, 14.9 at 64, 15.3 at 256, 21.8 at 1,024 (longer
// anchors, fewer pairs a byte of mask holds back).
constexpr std::size_t kAnchorPairs = 64;

class Classifier {
  public:
    Classifier(const std::vector<ClusterTree>& trees, const BlockerSet& blockers, double eps,
               const CancellationFlag& cancel, bool record_visible = false)
        : trees_(trees),
          blockers_(blockers),
          eps_(eps),
          cancel_(cancel),
          record_visible_(record_visible) {}

    void surface_pair(int ta, int tb, PairOutput& out) {
        pool_.clear();
        if (!root_candidates(trees_, blockers_, eps_, ta, tb, pool_)) return;
        recurse(ta, 0, tb, 0, 0, pool_.size(), out, nullptr);
    }

    /// What the classification of the pair of groups (ta, tb) will cost, from its first levels:
    /// it runs until node pairs hold at most `coarse` patch pairs, and adds up the node pairs
    /// it tested and, for each node pair still partly hidden there, its patch pairs times one
    /// plus its candidates (what the levels below test, and integrate later).
    double estimate(int ta, int tb, std::size_t coarse) {
        pool_.clear();
        if (!root_candidates(trees_, blockers_, eps_, ta, tb, pool_)) return 0.0;
        coarse_ = std::max<std::size_t>(coarse, 1);
        undecided_ = 0.0;
        PairOutput scratch;
        recurse(ta, 0, tb, 0, 0, pool_.size(), scratch, nullptr);
        coarse_ = 0;
        return double(scratch.node_pairs) + undecided_;
    }

  private:
    const std::vector<ClusterTree>& trees_;
    const BlockerSet& blockers_;
    double eps_;
    const CancellationFlag& cancel_;
    bool record_visible_ = false;
    std::vector<int> pool_, kept_;
    std::vector<int> last_kept_;            // the list of the last partly hidden pair stored
    const PairOutput* last_out_ = nullptr;  // ... and where
    std::size_t coarse_ = 0;  // estimate(): the size of node pairs it stops at (0: classify)
    double undecided_ = 0.0;

    // The anchor of the partly hidden pairs below a node pair (see CandidateLists): its list,
    // pool_[first, first + count), and where it is stored once a pair needs it.
    struct Anchor {
        std::size_t first = 0, count = 0, at = 0;
        bool stored = false;
    };

    void recurse(int ta, int a, int tb, int b, std::size_t first, std::size_t count,
                 PairOutput& out, Anchor* anchor) {
        const ClusterTree& TA = trees_[static_cast<std::size_t>(ta)];
        const ClusterTree& TB = trees_[static_cast<std::size_t>(tb)];
        const auto& A = TA.nodes[static_cast<std::size_t>(a)];
        const auto& B = TB.nodes[static_cast<std::size_t>(b)];
        // One pair of large surfaces (a city's ground and a facade) is seconds of node pairs.
        cancel_.throw_if_requested();
        ++out.node_pairs;
        Shaft sh;
        sh.build(A.hull.data(), static_cast<int>(A.hull.size()), TA.normal, B.hull.data(),
                 static_cast<int>(B.hull.size()), TB.normal, eps_);
        if (sh.facing_away()) return;
        // The exact (edge-edge) separation test only for patch pairs: above them a false
        // "partly hidden" costs one more level of recursion, below it an integration. Above
        // them, too, the pieces of a convex solid that meets the shaft are kept without a test
        // each (by_solid): their list only seeds the children's, which test them again. On the
        // urban array of 3,026 triangles that takes the classification from 5.8 to 3.9 s, for
        // 0.1% more node pairs and the same lists at the patch pairs. Not at the node pair whose
        // list becomes the anchor of the pairs below (CandidateLists): the pairs' lists are
        // stored against it, which whole solids would make longer.
        const bool leaves = A.count == 1 && B.count == 1;
        const std::size_t pairs =
            static_cast<std::size_t>(A.count) * static_cast<std::size_t>(B.count);
        const bool anchors = !anchor && pairs <= kAnchorPairs;
        const ShaftClass cls =
            detail::classify_shaft(sh, blockers_, pool_.data() + first, static_cast<int>(count),
                                   kept_, leaves, !leaves && !anchors);
        if (cls == ShaftClass::kHidden) {
            // The sparse rows leave hidden pairs out (their entries are 0): only counted.
            if (!record_visible_) out.hidden.push_back({ta, a, tb, b});
            out.hidden_patch_pairs += pairs;
            return;
        }
        if (cls == ShaftClass::kVisible) {
            out.visible_patch_pairs += pairs;
            if (record_visible_) out.visible.push_back({ta, a, tb, b});
            return;
        }
        if (coarse_ > 0 && pairs <= coarse_) {
            undecided_ += double(pairs) * (1.0 + double(kept_.size()));
            return;
        }
        if (leaves) {
            PartialPair p;
            p.i = TA.order[static_cast<std::size_t>(A.first)];
            p.j = TB.order[static_cast<std::size_t>(B.first)];
            // The pairs of one node pair often keep the same pieces: the list of the pair
            // before is shared when it is the same.
            if (!out.partial.empty() && last_out_ == &out && last_kept_ == kept_) {
                p.cand_first = out.partial.back().cand_first;
            } else {
                std::size_t at = 0;
                if (anchor) {
                    if (!anchor->stored) {
                        anchor->at =
                            out.cand.add_anchor(pool_.data() + anchor->first, anchor->count);
                        anchor->stored = true;
                    }
                    at = out.cand.add_subset(anchor->at, pool_.data() + anchor->first,
                                             anchor->count, kept_);
                } else {
                    at = out.cand.append(kept_);
                }
                if (at > UINT32_MAX)
                    throw ResourceError(
                        "analytic classification: the candidate lists of one pair of planes "
                        "exceed 4 GB; use a Monte-Carlo method (mc-hemisphere) for this scene");
                p.cand_first = static_cast<std::uint32_t>(at);
                last_kept_ = kept_;
                last_out_ = &out;
            }
            out.partial.push_back(p);
            return;
        }
        const std::size_t mine = pool_.size();
        pool_.insert(pool_.end(), kept_.begin(), kept_.end());
        const std::size_t n = kept_.size();
        Anchor own{mine, n};
        Anchor* below = anchor ? anchor : (pairs <= kAnchorPairs ? &own : nullptr);
        const bool split_a = B.count == 1 || (A.count > 1 && A.area >= B.area);
        if (split_a) {
            recurse(ta, A.left, tb, b, mine, n, out, below);
            recurse(ta, A.right, tb, b, mine, n, out, below);
        } else {
            recurse(ta, a, tb, B.left, mine, n, out, below);
            recurse(ta, a, tb, B.right, mine, n, out, below);
        }
        pool_.resize(mine);
    }
};

}  // namespace

void prepare_blockers(const MethodContext& ctx, Obstructions& S) {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const auto t_start = Clock::now();
    announce_phase("analytic setup");
    const std::size_t n = scene.patches.size();
    Bounds3 box = scene.bounds();
    for (const Patch& p : scene.patches)
        for (const Vec3& v : p.polygon.vertices) box.extend(v);
    const double diag = box.empty() ? 1.0 : box.diagonal().norm();
    // Groups of patches: those in one plane with one orientation (whatever surfaces they came
    // from: a VS3 file may list every patch as a surface). Nothing in a group can block a pair
    // involving the group, and a group's patches often tile a convex region, which then blocks
    // as one piece. Obstruction-only surfaces are grouped the same way (apart from the
    // patches), so that a box given as many small obstruction records blocks as the same
    // few pieces as the box given as whole faces.
    std::vector<TreeItem>& items = S.items;
    std::vector<ClusterTree>& trees = S.trees;
    std::vector<ClusterTree>& otrees = S.otrees;
    BlockerSet& blockers = S.blockers;
    items.reserve(n);
    for (const Patch& p : scene.patches) items.push_back({&p.polygon, p.centroid, p.area});
    auto group = [&](std::vector<ClusterTree>& dst, std::size_t first, std::size_t last,
                     int id_base) {
        std::map<std::array<long long, 4>, int> key_to_group;
        for (std::size_t p = first; p < last; ++p) {
            const TreeItem& it = items[p];
            const Vec3 nn = normal(*it.polygon);
            const double d = nn.dot(it.centroid) / diag;
            const std::array<long long, 4> key = {
                std::llround(nn.x() * 1e8), std::llround(nn.y() * 1e8), std::llround(nn.z() * 1e8),
                std::llround(d * 1e8)};
            auto g = key_to_group.find(key);
            if (g == key_to_group.end()) {
                g = key_to_group.emplace(key, static_cast<int>(dst.size())).first;
                ClusterTree t;
                t.normal = nn;
                t.blocker_id = id_base + static_cast<int>(dst.size());
                dst.push_back(std::move(t));
            }
            dst[static_cast<std::size_t>(g->second)].order.push_back(static_cast<int>(p));
        }
    };
    group(trees, 0, n, 0);
    for (const Surface& s : scene.surfaces)
        if (s.obstruction && area(s.polygon) > 0.0)
            items.push_back({&s.polygon, centroid(s.polygon), area(s.polygon)});
    group(otrees, n, items.size(), static_cast<int>(trees.size()));
    parallel_for(trees.size() + otrees.size(), options.threads, [&](std::size_t t) {
        ClusterTree& T = t < trees.size() ? trees[t] : otrees[t - trees.size()];
        T.build(items, 0, static_cast<int>(T.order.size()));
    });
    // A group whose plane has every patch vertex on one side (within half the shafts' eps, so
    // that each piece's own plane agrees) blocks nothing: a segment between two patches meets
    // that plane at most at its ends. Every shaft would find its pieces outside by their plane
    // (Shaft::piece_outside()), after its other planes: no shaft's query finds them (the ground
    // under a city, 61% of the candidates the node pairs of the 1,066-triangle urban array
    // tested; the walls of a convex room). They stay pieces, for the solids' edges
    // (mark_closed_solids()).
    const double half_eps = 0.5e-11 * diag;
    std::vector<char> one_sided(trees.size() + otrees.size(), 0);
    parallel_for(one_sided.size(), options.threads, [&](std::size_t t) {
        const ClusterTree& T = t < trees.size() ? trees[t] : otrees[t - trees.size()];
        const Vec3& o = items[static_cast<std::size_t>(T.order[0])].polygon->vertices.front();
        const double d = T.normal.dot(o);
        bool below = false, above = false;
        for (const Patch& p : scene.patches) {
            for (const Vec3& v : p.polygon.vertices) {
                const double s = T.normal.dot(v) - d;
                below = below || s < -half_eps;
                above = above || s > half_eps;
            }
            if (below && above) return;
        }
        one_sided[t] = 1;
    });
    S.one_sided_groups =
        static_cast<std::size_t>(std::count(one_sided.begin(), one_sided.end(), 1));
    // Blockers: for each group, the largest tree nodes whose polygons tile their hull (one
    // convex piece each), else single polygons.
    std::size_t& merged_pieces = S.merged_pieces;
    const CancellationFlag& setup_cancel = current_cancellation();  // serial: polled per node
    for (std::size_t t = 0; t < trees.size() + otrees.size(); ++t) {
        const ClusterTree& T = t < trees.size() ? trees[t] : otrees[t - trees.size()];
        std::vector<int> stack = {0};
        while (!stack.empty()) {
            setup_cancel.throw_if_requested();
            const auto& nd = T.nodes[static_cast<std::size_t>(stack.back())];
            stack.pop_back();
            double sum = 0.0;
            for (int k = nd.first; k < nd.first + nd.count; ++k)
                sum += items[static_cast<std::size_t>(T.order[static_cast<std::size_t>(k)])].area;
            if (nd.count == 1) {
                blockers.add(
                    *items[static_cast<std::size_t>(T.order[static_cast<std::size_t>(nd.first)])]
                         .polygon,
                    T.blocker_id);
            } else if (Polygon hp; tiled_hull(T, nd, items, sum, hp)) {
                blockers.add(hp, T.blocker_id);
                ++merged_pieces;
            } else {
                stack.push_back(nd.left);
                stack.push_back(nd.right);
            }
        }
    }
    blockers.build(one_sided);
    {
        std::vector<std::pair<Bounds3, int>> patch_boxes;
        for (const ClusterTree& t : trees)
            for (int p : t.order) {
                Bounds3 b;
                for (const Vec3& v : scene.patches[static_cast<std::size_t>(p)].polygon.vertices)
                    b.extend(v);
                patch_boxes.emplace_back(b, t.blocker_id);
            }
        blockers.mark_closed_solids(patch_boxes, 1e-9 * diag);
    }

    S.eps = 1e-11 * diag;
    S.seconds_setup = seconds(t_start, Clock::now());
}

std::size_t classification_tasks(const Obstructions& S) {
    const std::size_t g = S.trees.size();
    return g < 2 ? 0 : g * (g - 1) / 2;
}

namespace {

// Task k is the k-th unordered pair (a, b), a < b, of plane groups in row order.
std::vector<std::array<int, 2>> task_groups(const Obstructions& S) {
    const std::size_t g = S.trees.size();
    std::vector<std::array<int, 2>> groups;
    groups.reserve(classification_tasks(S));
    for (std::size_t a = 0; a < g; ++a)
        for (std::size_t b = a + 1; b < g; ++b)
            groups.push_back({static_cast<int>(a), static_cast<int>(b)});
    return groups;
}

}  // namespace

namespace {

void put_varint(std::vector<std::uint8_t>& bytes, std::uint64_t z) {
    while (z >= 0x80) {
        bytes.push_back(static_cast<std::uint8_t>(z | 0x80));
        z >>= 7;
    }
    bytes.push_back(static_cast<std::uint8_t>(z));
}

bool get_varint(const std::vector<std::uint8_t>& bytes, std::size_t& at, std::uint64_t& z) {
    z = 0;
    for (int shift = 0;; shift += 7) {
        if (at >= bytes.size() || shift > 63) return false;
        const std::uint8_t b = bytes[at++];
        z |= static_cast<std::uint64_t>(b & 0x7f) << shift;
        if (!(b & 0x80)) return true;
    }
}

}  // namespace

std::size_t CandidateLists::add_anchor(const int* ids, std::size_t count) {
    const std::size_t first = bytes.size();
    put_varint(bytes, count);
    std::int64_t prev = 0;
    for (std::size_t k = 0; k < count; ++k) {
        const std::int64_t d = std::int64_t{ids[k]} - prev;
        prev = ids[k];
        put_varint(bytes, static_cast<std::uint64_t>((d << 1) ^ (d >> 63)));  // zigzag
    }
    return first;
}

std::size_t CandidateLists::add_subset(std::size_t anchor, const int* anchor_ids,
                                       std::size_t anchor_count, const std::vector<int>& kept) {
    const std::size_t first = bytes.size();
    FF_ASSERT(anchor < first);
    put_varint(bytes, first - anchor);
    const std::size_t mask = bytes.size();
    bytes.resize(mask + (anchor_count + 7) / 8, 0);
    std::size_t k = 0;
    for (std::size_t a = 0; a < anchor_count && k < kept.size(); ++a)
        if (anchor_ids[a] == kept[k]) {
            bytes[mask + a / 8] |= static_cast<std::uint8_t>(1u << (a % 8));
            ++k;
        }
    FF_ASSERT(k == kept.size());  // kept is a subsequence of the anchor's list
    return first;
}

std::size_t CandidateLists::append(const std::vector<int>& ids) {
    const std::size_t anchor = add_anchor(ids.data(), ids.size());
    return add_subset(anchor, ids.data(), ids.size(), ids);
}

bool CandidateLists::decode(std::size_t first, std::vector<int>& ids) const {
    ids.clear();
    std::size_t at = first;
    std::uint64_t back = 0, m = 0;
    if (!get_varint(bytes, at, back) || back == 0 || back > first) return false;
    std::size_t anchor = first - static_cast<std::size_t>(back);
    if (!get_varint(bytes, anchor, m) || m > bytes.size()) return false;
    const std::size_t mask = at;
    if ((m + 7) / 8 > bytes.size() - mask) return false;
    auto kept = [&](std::size_t k) { return (bytes[mask + k / 8] >> (k % 8)) & 1u; };
    // The anchor's ids up to the pair's last one (the mask holds no bit beyond it).
    std::size_t last = m;
    while (last > 0 && !kept(last - 1)) --last;
    std::int64_t prev = 0;
    for (std::size_t k = 0; k < last; ++k) {
        std::uint64_t z = 0;
        if (!get_varint(bytes, anchor, z)) return false;
        prev += static_cast<std::int64_t>(z >> 1) ^ -static_cast<std::int64_t>(z & 1);
        if (prev < 0 || prev > std::numeric_limits<int>::max()) return false;
        if (kept(k)) ids.push_back(static_cast<int>(prev));
    }
    return true;
}

void classify_task_list(const Obstructions& S, const std::size_t* tasks, std::size_t count,
                        bool record_visible, int threads, PairOutput* out) {
    const std::vector<std::array<int, 2>> all = task_groups(S);
    std::vector<std::array<int, 2>> spairs(count);
    for (std::size_t q = 0; q < count; ++q) {
        if (tasks[q] >= all.size()) throw Error("analytic: a classification task out of range");
        spairs[q] = all[tasks[q]];
    }
    const CancellationFlag& cancel = current_cancellation();
    parallel_for_each(spairs.size(), threads, [&](std::size_t q) {
        Classifier c(S.trees, S.blockers, S.eps, cancel, record_visible);
        c.surface_pair(spairs[q][0], spairs[q][1], out[q]);
        // The lists stay until the partly hidden pass is done: without the room their growth
        // left (on a city, 44% more than the candidates).
        out[q].partial.shrink_to_fit();
        out[q].cand.bytes.shrink_to_fit();
        out[q].hidden.shrink_to_fit();
        out[q].visible.shrink_to_fit();
    });
}

void classify_tasks(const Obstructions& S, RowRange tasks, bool record_visible, int threads,
                    PairOutput* out) {
    tasks = tasks.clamped(classification_tasks(S));
    std::vector<std::size_t> list(tasks.size());
    std::iota(list.begin(), list.end(), tasks.begin);
    classify_task_list(S, list.data(), list.size(), record_visible, threads, out);
}

std::vector<std::size_t> tasks_by_size(const Obstructions& S) {
    const std::vector<std::array<int, 2>> groups = task_groups(S);
    auto pairs = [&](std::size_t k) {
        return std::size_t(S.trees[static_cast<std::size_t>(groups[k][0])].nodes[0].count) *
               std::size_t(S.trees[static_cast<std::size_t>(groups[k][1])].nodes[0].count);
    };
    std::vector<std::size_t> order(groups.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return pairs(a) > pairs(b); });
    return order;
}

std::vector<std::size_t> classification_order(const Obstructions& S) {
    const std::vector<std::array<int, 2>> groups = task_groups(S);
    std::vector<double> cost(groups.size(), 0.0);
    // The first levels of each task's classification, down to about 256 node pairs: the patch
    // pairs times the blocker pieces of the root shaft would rank alike all 15 pairs of walls of
    // room-32, whose classifications take from 0.1 to 0.6 s.
    Classifier c(S.trees, S.blockers, S.eps, current_cancellation());
    for (std::size_t k = 0; k < groups.size(); ++k) {
        const std::size_t pairs =
            std::size_t(S.trees[static_cast<std::size_t>(groups[k][0])].nodes[0].count) *
            std::size_t(S.trees[static_cast<std::size_t>(groups[k][1])].nodes[0].count);
        cost[k] = c.estimate(groups[k][0], groups[k][1], pairs / 256);
    }
    std::vector<std::size_t> order(groups.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return cost[a] > cost[b]; });
    return order;
}

void prepare_obstructions(const MethodContext& ctx, bool record_visible, Obstructions& S) {
    prepare_blockers(ctx, S);
    // 1. Classification, one task per unordered pair of surfaces.
    const auto t_setup = Clock::now();
    S.outputs.assign(classification_tasks(S), PairOutput{});
    announce_phase("analytic classification");
    classify_tasks(S, RowRange{0, S.outputs.size()}, record_visible, ctx.options.threads,
                   S.outputs.data());
    S.seconds_classification = seconds(t_setup, Clock::now());
}

}  // namespace formfactor::detail
