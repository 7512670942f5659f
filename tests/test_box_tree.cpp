// The bounding-volume tree shared by the blocker set of the analytic method and the shaft
// culler of mc-target (src/geometry/box_tree.h): both skip what a node's box rules out, so a
// wrong box or a lost item would drop a blocker from both at once.

#include <doctest/doctest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "geometry/box_tree.h"

using namespace formfactor;
using detail::BoxTree;

namespace {

bool contains(const Bounds3& outer, const Bounds3& inner) {
    return (outer.lo.array() <= inner.lo.array()).all() &&
           (outer.hi.array() >= inner.hi.array()).all();
}

}  // namespace

TEST_CASE("box tree: every item in one leaf, boxes bound their items, splits at the median") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> pos(-10.0, 10.0), size(0.0, 2.0);
    constexpr int kLeafSize = 4;
    for (const int count : {0, 1, 4, 5, 9, 37, 200}) {
        CAPTURE(count);
        const auto n = static_cast<std::size_t>(count);
        std::vector<Bounds3> boxes(n);
        for (Bounds3& b : boxes) {
            const Vec3 lo(pos(rng), pos(rng), 0.1 * pos(rng));  // flat in z: the split axis varies
            b.extend(lo);
            b.extend(lo + Vec3(size(rng), size(rng), size(rng)));
        }
        BoxTree tree;
        tree.build(
            n, [&](int k) -> const Bounds3& { return boxes[static_cast<std::size_t>(k)]; },
            kLeafSize);
        if (n == 0) {
            CHECK(tree.nodes.empty());
            CHECK(tree.order.empty());
            continue;
        }
        std::vector<int> sorted = tree.order;
        std::sort(sorted.begin(), sorted.end());
        for (std::size_t k = 0; k < n; ++k) REQUIRE(sorted[k] == static_cast<int>(k));

        // Walk the tree depth first, tracking each subtree's range of `order`.
        std::vector<int> seen(n, 0);
        struct Item {
            int node, first, count;
        };
        std::vector<Item> stack = {{0, 0, count}};
        int next_id = 0;
        while (!stack.empty()) {
            const Item it = stack.back();
            stack.pop_back();
            CHECK(it.node == next_id++);  // depth-first numbering, left before right
            const BoxTree::Node& nd = tree.nodes[static_cast<std::size_t>(it.node)];
            for (int k = it.first; k < it.first + it.count; ++k)
                CHECK(contains(
                    nd.box,
                    boxes[static_cast<std::size_t>(tree.order[static_cast<std::size_t>(k)])]));
            if (nd.left < 0) {
                CHECK(nd.right < 0);
                CHECK(nd.first == it.first);
                CHECK(nd.count == it.count);
                CHECK(nd.count >= 1);
                CHECK(nd.count <= kLeafSize);
                for (int k = nd.first; k < nd.first + nd.count; ++k)
                    ++seen[static_cast<std::size_t>(tree.order[static_cast<std::size_t>(k)])];
                continue;
            }
            REQUIRE(it.count > kLeafSize);
            const int half = it.count / 2;
            // Along some axis, no item left of the median lies beyond one right of it.
            bool median = false;
            for (int axis = 0; axis < 3 && !median; ++axis) {
                double left_max = -1e300, right_min = 1e300;
                for (int k = it.first; k < it.first + it.count; ++k) {
                    const Bounds3& b =
                        boxes[static_cast<std::size_t>(tree.order[static_cast<std::size_t>(k)])];
                    const double key = b.lo[axis] + b.hi[axis];
                    if (k < it.first + half)
                        left_max = std::max(left_max, key);
                    else
                        right_min = std::min(right_min, key);
                }
                median = left_max <= right_min;
            }
            CHECK(median);
            stack.push_back({nd.right, it.first + half, it.count - half});
            stack.push_back({nd.left, it.first, half});
        }
        CHECK(next_id == static_cast<int>(tree.nodes.size()));
        CHECK(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
    }
}
