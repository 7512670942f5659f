// The obstruction pass of the `analytic` method over the dense matrix or a block of rows: after
// the classification of patch pairs (classification.cpp), the fully hidden pairs are set to 0 and
// every partly hidden pair is settled by integrate_partial() (partial_pair.h: the exact
// unobstructed value less its hidden part, by its bracket [0, unobstructed], the umbrae of its
// occluders, or Walton's adaptive integration, NISTIR 6925), or its value is taken from the
// partly hidden pairs computed apart from the rows (partly_hidden_pairs.cpp,
// formfactor/methods/partly_hidden.h). Sparse rows: sparse_rows.cpp. See docs/analytic.md,
// "Obstructed scenes".

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/core/progress.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/partly_hidden.h"
#include "methods/analytic/analytic_method.h"
#include "methods/analytic/classification.h"
#include "methods/analytic/partial_pair.h"
#include "methods/analytic/partly_hidden_pairs.h"
#include "methods/analytic/partly_hidden_pass.h"

namespace formfactor {

namespace {

using detail::add_pair;
using detail::checked_tolerance;
using detail::Clock;
using detail::ClusterTree;
using detail::combined;
using detail::for_each_patch_pair;
using detail::given_pairs;
using detail::integrate_partial;
using detail::NodePair;
using detail::Obstructions;
using detail::PairOutput;
using detail::PartialPair;
using detail::PartialValue;
using detail::partly_hidden_pass;
using detail::prepare_obstructions;
using detail::report_obstructions;
using detail::seconds;
using detail::ThreadStats;

}  // namespace

const detail::PatchTable* AnalyticMethod::given_table(const MethodContext& ctx) {
    return ctx.partly_hidden ? ctx.partly_hidden->impl().table.get() : nullptr;
}

void AnalyticMethod::apply_obstructions(const MethodContext& ctx, FormFactors& out, Fields& details,
                                        detail::UnobstructedBlock* block) {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const double tol = checked_tolerance(options);
    const std::size_t n = scene.patches.size();
    const PartlyHiddenPairs::Impl* given = given_pairs(ctx, false);
    Obstructions own;
    if (!given) prepare_obstructions(ctx, false, own);
    const Obstructions& S = given ? given->S : own;
    const std::vector<ClusterTree>& trees = S.trees;
    const std::vector<PairOutput>& outputs = S.outputs;
    const auto t_classified = Clock::now();
    // 2. Fully hidden node pairs: zero.
    double* F = out.F.data();
    std::vector<NodePair> hidden;
    std::vector<PartialPair> partial;
    std::vector<std::size_t> cand_task, index;  // index: the pair's place in the whole list
    std::size_t node_pairs = 0, vis = 0, hid = 0;
    // A block of rows takes only the partly hidden pairs with a patch in it (3.), each with its
    // place in the whole list.
    std::size_t whole = 0;
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        hidden.insert(hidden.end(), outputs[k].hidden.begin(), outputs[k].hidden.end());
        for (const PartialPair& p : outputs[k].partial) {
            const std::size_t at = whole++;
            if (block && !block->rows.contains(static_cast<std::size_t>(p.i)) &&
                !block->rows.contains(static_cast<std::size_t>(p.j)))
                continue;
            index.push_back(at);
            partial.push_back(p);
            cand_task.push_back(k);
        }
        node_pairs += outputs[k].node_pairs;
        vis += outputs[k].visible_patch_pairs;
        hid += outputs[k].hidden_patch_pairs;
    }
    parallel_for(hidden.size(), options.threads, [&](std::size_t k) {
        if (block) {
            // The rows of each node that are in the block, not every patch pair of the two.
            const NodePair& np = hidden[k];
            const ClusterTree& TA = trees[static_cast<std::size_t>(np.ta)];
            const ClusterTree& TB = trees[static_cast<std::size_t>(np.tb)];
            const auto& A = TA.nodes[static_cast<std::size_t>(np.a)];
            const auto& B = TB.nodes[static_cast<std::size_t>(np.b)];
            auto rows_of = [&](const ClusterTree& T, const ClusterTree::Node& P,
                               const ClusterTree& U, const ClusterTree::Node& Q) {
                for (int x = P.first; x < P.first + P.count; ++x) {
                    const auto i = static_cast<std::size_t>(T.order[static_cast<std::size_t>(x)]);
                    if (!block->rows.contains(i)) continue;
                    for (int y = Q.first; y < Q.first + Q.count; ++y)
                        block->set(
                            i, static_cast<std::size_t>(U.order[static_cast<std::size_t>(y)]), 0.0);
                }
            };
            rows_of(TA, A, TB, B);
            rows_of(TB, B, TA, A);
            return;
        }
        for_each_patch_pair(trees, hidden[k], [&](std::size_t i, std::size_t j) {
            F[i * n + j] = 0.0;
            F[j * n + i] = 0.0;
        });
    });

    // 3. Partly hidden pairs: exact unobstructed value minus the integrated hidden part, over
    // the smaller patch of the pair (reciprocity gives the other entry, with a smaller error).
    ThreadStats stats;
    Fields& o = details["obstructions"];
    auto pair_value = [&](std::size_t k) {
        if (given) return given->value(index[k]);
        return integrate_partial(scene, S, partial[k], outputs[cand_task[k]].cand, tol,
                                 [&](std::size_t s, std::size_t r) {
                                     return block ? block->unobstructed(s, r) : F[s * n + r];
                                 });
    };
    auto body = [&](std::size_t k) {
        const PartialValue v = pair_value(k);
        if (v.integrated) {
            if (block) {
                block->set(v.s, v.r, v.f);
                block->set(v.r, v.s, v.back);
            } else {
                F[v.s * n + v.r] = v.f;
                F[v.r * n + v.s] = v.back;
            }
        }
        add_pair(stats.local(), v.stats);
    };
    if (given)
        parallel_for(partial.size(), options.threads, body);
    else
        partly_hidden_pass(partial.size(), ctx, tol, o, body);
    const auto t_done = Clock::now();
    // Given pairs: the integration of every pair of the scene, wherever it ran.
    report_obstructions(S, given ? given->values.stats : combined(stats), node_pairs, vis, hid,
                        given ? given->partial.size() : partial.size(), tol,
                        effective_threads(options.threads), o);
    o["seconds_partly_hidden"] = seconds(t_classified, t_done);
}

}  // namespace formfactor
