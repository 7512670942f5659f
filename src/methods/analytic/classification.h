#pragma once
// The classification of the obstructed analytic method (classification.cpp): patch pairs sorted
// into visible, hidden and partly hidden by shafts between cluster nodes against the blocker
// pieces, hierarchically (Haines & Wallace 1994, shaft culling; Hanrahan, Salzman & Aupperle
// 1991, the hierarchy). What the dense pass and the sparse rows of analytic_obstructed.cpp share.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"
#include "methods/analytic/analytic_method.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor::detail {

// A polygon that a cluster tree holds: a patch, or an obstruction-only surface.
struct TreeItem {
    const Polygon* polygon = nullptr;
    Vec3 centroid = Vec3::Zero();
    double area = 0.0;
};

// A hierarchy of coplanar polygons (the patches of one plane group, or its obstruction-only
// surfaces): nodes bound their polygons by the planar convex hull of their vertices (a superset
// of their union, so every shaft test stays conservative).
struct ClusterTree {
    struct Node {
        std::vector<Vec3> hull;
        double area = 0;
        int left = -1, right = -1;
        int first = 0, count = 0;  // order[first, first + count)
    };
    std::vector<Node> nodes;
    std::vector<int> order;  // indices into the items the tree was built on
    Vec3 normal = Vec3::UnitZ();
    int blocker_id = -1;  // the id of this group's pieces in the BlockerSet

    /// Builds the node over order[first, first + count) (items' indices); returns its id.
    int build(const std::vector<TreeItem>& items, int first, int count);
};

struct PartialPair {
    int i = 0, j = 0;
    std::uint32_t cand_first = 0;  // its list's record in CandidateLists::bytes
};
static_assert(sizeof(PartialPair) == 12);

// The candidate pieces of the partly hidden pairs of one classification task. A pair's list is
// what its shaft keeps of the list of a node pair above it (its anchor: the first node pair of
// at most kAnchorPairs patch pairs on the way down, or the pair itself), in the same order, so
// it is stored as a bit mask over the anchor's list, which its pairs share. Records:
//   anchor: varint m, then m LEB128 varints of the zigzagged differences between consecutive
//           piece indices (a BVH walk: neighbours in index, mostly one byte each);
//   pair:   varint (the pair's offset − its anchor's offset), then ⌈m/8⌉ bytes of mask (bit k
//           of byte k/8: the anchor's k-th piece is kept).
// On the urban array of 9,946 triangles a list of its own took 47 bytes a pair.
struct CandidateLists {
    std::vector<std::uint8_t> bytes;
    /// Appends an anchor's list; returns its offset.
    std::size_t add_anchor(const int* ids, std::size_t count);
    /// Appends a pair's list `kept`, a subsequence of the anchor's (anchor_ids, anchor_count)
    /// stored at `anchor`; returns its offset.
    std::size_t add_subset(std::size_t anchor, const int* anchor_ids, std::size_t anchor_count,
                           const std::vector<int>& kept);
    /// A list that is its own anchor; returns the offset of its pair record.
    std::size_t append(const std::vector<int>& ids);
    /// The ids of the pair record at byte `first`, into `ids`; false when the bytes end first,
    /// the record is malformed or an id is negative.
    bool decode(std::size_t first, std::vector<int>& ids) const;
};

struct NodePair {
    int ta, a, tb, b;  // tree and node indices
};

// What one surface pair's classification produced.
struct PairOutput {
    std::vector<NodePair> hidden;   // only for the dense pass (the sparse rows leave them out)
    std::vector<NodePair> visible;  // only when the classifier records them (sparse rows)
    std::vector<PartialPair> partial;
    CandidateLists cand;
    std::size_t node_pairs = 0;
    std::size_t visible_patch_pairs = 0, hidden_patch_pairs = 0;
};

using Clock = std::chrono::steady_clock;
inline double seconds(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

// The blockers and the classification of every patch pair of a scene that may obstruct: what
// the dense pass and the sparse rows share.
struct Obstructions {
    std::vector<TreeItem> items;
    std::vector<ClusterTree> trees, otrees;  // patches' and obstruction-only plane groups
    BlockerSet blockers;
    std::size_t merged_pieces = 0;
    std::size_t one_sided_groups = 0;  // plane groups with every patch on one side: no blockers
    double eps = 0;
    std::vector<PairOutput> outputs;  // one per unordered pair of plane groups
    double seconds_setup = 0, seconds_classification = 0;
};

/// Groups the scene's patches and obstruction-only surfaces by plane, builds their cluster trees
/// and the blocker pieces, and classifies every pair of groups (in parallel; announces the
/// phases "analytic setup" and "analytic classification"). record_visible: keep the visible
/// node pairs instead of the hidden ones (the sparse rows need them, and leave hidden pairs out).
void prepare_obstructions(const MethodContext& ctx, bool record_visible, Obstructions& S);

/// prepare_obstructions() in parts, for a classification shared out over processes: the groups,
/// trees and blockers (S.outputs empty); the classification's tasks (one per unordered pair of
/// plane groups, in the order of S.outputs); and the outputs of tasks [tasks.begin, tasks.end)
/// into out[0, tasks.size()), each bit for bit what prepare_obstructions() puts in S.outputs.
void prepare_blockers(const MethodContext& ctx, Obstructions& S);
std::size_t classification_tasks(const Obstructions& S);
void classify_tasks(const Obstructions& S, RowRange tasks, bool record_visible, int threads,
                    PairOutput* out);
/// The tasks by their estimated cost, the largest first (ties in task order), from the first
/// levels of each one's classification (node pairs of down to 1/256 of its patch pairs): a
/// classification shared out task by task in this order ends with small tasks.
std::vector<std::size_t> classification_order(const Obstructions& S);
/// The tasks by their patch pairs, the largest first (ties in task order): a rough order of
/// their cost, at no cost.
std::vector<std::size_t> tasks_by_size(const Obstructions& S);
/// The outputs of tasks[0, count) (task indices) into out[0, count), as classify_tasks().
void classify_task_list(const Obstructions& S, const std::size_t* tasks, std::size_t count,
                        bool record_visible, int threads, PairOutput* out);

// f(i, j) for every patch pair (i of node a, j of node b) of a node pair.
template <class F>
void for_each_patch_pair(const std::vector<ClusterTree>& trees, const NodePair& np, const F& f) {
    const ClusterTree& TA = trees[static_cast<std::size_t>(np.ta)];
    const ClusterTree& TB = trees[static_cast<std::size_t>(np.tb)];
    const auto& A = TA.nodes[static_cast<std::size_t>(np.a)];
    const auto& B = TB.nodes[static_cast<std::size_t>(np.b)];
    for (int x = A.first; x < A.first + A.count; ++x)
        for (int y = B.first; y < B.first + B.count; ++y)
            f(static_cast<std::size_t>(TA.order[static_cast<std::size_t>(x)]),
              static_cast<std::size_t>(TB.order[static_cast<std::size_t>(y)]));
}

}  // namespace formfactor::detail
