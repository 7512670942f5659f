#pragma once
// What PartlyHiddenPairs holds (formfactor/methods/partly_hidden.h; not public API): the
// classification of a scene that may obstruct, its list of partly hidden pairs, and their values
// once set. partly_hidden_pairs.cpp computes it; the passes of analytic_obstructed.cpp take the
// values from it when it is given (MethodContext::partly_hidden). See docs/analytic.md,
// "Obstructed scenes".

#include <algorithm>
#include <cstddef>
#include <memory>
#include <tuple>
#include <vector>

#include "formfactor/methods/method.h"
#include "formfactor/methods/partly_hidden.h"
#include "formfactor/scene/scene.h"
#include "kernels/unobstructed.h"
#include "methods/analytic/classification.h"
#include "methods/analytic/partial_pair.h"

namespace formfactor {

namespace detail {

// A sample of a list of `count` partly hidden pairs: every stride-th pair, about count / 64 of
// them, at least 256 and at most 4,096 (the time of a sample estimates a sum of heavy-tailed
// costs: on a triangulated urban array of 3,026 facets, 256 pairs gave 0.6-1.5 times the whole
// pass, 4,096 pairs 0.9-1.16 times, depending on the first pair). The partly hidden pass runs it
// first, for its time estimate (analytic_obstructed.cpp), and PartlyHiddenPairs::integrate()
// takes its parts of an order that starts with it.
inline std::size_t sample_stride(std::size_t count) {
    const std::size_t wanted = std::clamp<std::size_t>(count / 64, 256, 4096);
    return std::max<std::size_t>(1, count / wanted);
}

// The pair at position j of that order over `count` pairs: every stride-th from 0, then from 1,
// and so on (computed, not listed: a list takes 8 bytes a pair).
inline std::size_t strided_pair(std::size_t j, std::size_t count, std::size_t stride) {
    const std::size_t g = count / stride, m = count % stride;  // m runs of g + 1, then runs of g
    if (j < m * (g + 1)) return j / (g + 1) + (j % (g + 1)) * stride;
    const std::size_t rest = j - m * (g + 1);
    return m + rest / g + (rest % g) * stride;
}

}  // namespace detail

struct PartlyHiddenPairs::Impl {
    Impl(const Scene& sc, const MethodOptions& o) : scene(sc), options(o) {}
    const Scene& scene;
    MethodOptions options;
    bool sparse = false;
    double tol = 0, visible_tol = 0;
    detail::Obstructions S;
    // Every partly hidden pair in the classification's order (the order apply_obstructions()
    // and sparse_obstructed_rows() list them in), with the output holding its candidates.
    std::vector<detail::PartialPair> partial;
    std::vector<std::size_t> cand_task;
    std::vector<std::size_t> order;  // integrate()'s positions → pairs
    // classify()'s positions → tasks (detail::classification_order(); classify = false only).
    std::vector<std::size_t> task_order;
    // The patches' table of the unobstructed values, for every part and block of rows.
    std::shared_ptr<const detail::PatchTable> table;

    // partial, cand_task and order from S.outputs.
    void list_pairs();
    PartlyHiddenValues values;  // by pair, once set
    bool has_values = false;

    // values as integrate_partial() gives them, for pair k.
    detail::PartialValue value(std::size_t k) const {
        detail::PartialValue v;
        std::tie(v.s, v.r) = detail::sender_receiver(scene, partial[k]);
        v.f = values.f[k];
        v.back = values.back[k];
        v.integrated = values.integrated[k] != 0;
        return v;
    }
};

}  // namespace formfactor
