#pragma once
// A bounding-volume hierarchy over items with boxes (private to the library), built by median
// splits. Shared by the analytic method's blocker set (src/methods/analytic/blocker_set.cpp) and
// the shaft culler (src/visibility/shaft_culler.cpp): only the tree; what each tests against its
// boxes stays with it.

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor::detail {

/// A binary tree of boxes over items 0..n−1. Node 0 is the root; nodes are in depth-first order
/// (a node, then its left subtree, then its right).
struct BoxTree {
    struct Node {
        Bounds3 box;                ///< bounds the boxes of the node's items
        int left = -1, right = -1;  ///< children, or −1 for a leaf
        int first = 0, count = 0;   ///< a leaf's items: order[first, first + count)
    };
    std::vector<Node> nodes;  ///< empty when there are no items
    std::vector<int> order;   ///< the item indices, each subtree's items contiguous

    /// Builds the tree over n items, box_of(k) returning item k's Bounds3: a node holding more
    /// than leaf_size items splits them at the median of their box centres along the axis
    /// where the centres spread most (ties in any order).
    template <class BoxOf>
    void build(std::size_t n, const BoxOf& box_of, int leaf_size) {
        nodes.clear();
        order.resize(n);
        std::iota(order.begin(), order.end(), 0);
        if (n == 0) return;
        nodes.reserve(2 * n);
        build_node(box_of, leaf_size, 0, static_cast<int>(n));
    }

  private:
    template <class BoxOf>
    int build_node(const BoxOf& box_of, int leaf_size, int first, int count) {
        const int id = static_cast<int>(nodes.size());
        nodes.push_back({});
        Bounds3 box, cbox;
        for (int k = first; k < first + count; ++k) {
            const Bounds3& b = box_of(order[static_cast<std::size_t>(k)]);
            box.extend(b.lo);
            box.extend(b.hi);
            cbox.extend(0.5 * (b.lo + b.hi));
        }
        nodes[static_cast<std::size_t>(id)].box = box;
        if (count <= leaf_size) {
            nodes[static_cast<std::size_t>(id)].first = first;
            nodes[static_cast<std::size_t>(id)].count = count;
            return id;
        }
        int axis = 0;
        const Vec3 ext = cbox.diagonal();
        if (ext.y() > ext[axis]) axis = 1;
        if (ext.z() > ext[axis]) axis = 2;
        const int mid = first + count / 2;
        std::nth_element(order.begin() + first, order.begin() + mid, order.begin() + first + count,
                         [&](int a, int b) {
                             const Bounds3& ba = box_of(a);
                             const Bounds3& bb = box_of(b);
                             return ba.lo[axis] + ba.hi[axis] < bb.lo[axis] + bb.hi[axis];
                         });
        const int l = build_node(box_of, leaf_size, first, mid - first);
        const int r = build_node(box_of, leaf_size, mid, first + count - mid);
        nodes[static_cast<std::size_t>(id)].left = l;
        nodes[static_cast<std::size_t>(id)].right = r;
        return id;
    }
};

}  // namespace formfactor::detail
