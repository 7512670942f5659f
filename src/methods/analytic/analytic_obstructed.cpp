// The obstruction pass of the `analytic` method: after the classification of patch pairs
// (classification.cpp), the fully hidden pairs are set to 0 and every partly hidden pair is
// settled by integrate_partial() (partial_pair.h: the exact unobstructed value less its hidden
// part, by its bracket [0, unobstructed], the umbrae of its occluders, or Walton's adaptive
// integration, NISTIR 6925), in the dense matrix, in a block of rows, or in sparse rows; or
// its value is taken from the partly hidden pairs computed apart from the rows
// (partly_hidden_pairs.cpp, formfactor/methods/partly_hidden.h). See docs/analytic.md,
// "Obstructed scenes".

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
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

namespace formfactor {

namespace {

using detail::add_pair;
using detail::checked_tolerance;
using detail::Clock;
using detail::ClusterTree;
using detail::combined;
using detail::for_each_patch_pair;
using detail::integrate_partial;
using detail::NodePair;
using detail::Obstructions;
using detail::PairOutput;
using detail::PartialPair;
using detail::PartialValue;
using detail::prepare_obstructions;
using detail::report_obstructions;
using detail::sample_stride;
using detail::seconds;
using detail::ThreadStats;

// The partly hidden pass: body(k) for every pair k < count, in an order whose first pairs are
// spread evenly over the list (every stride-th), so that they are a sample of the whole: the
// progress bar's rate holds from the start, and the time they take, scaled, is the pass's.
// That estimate goes into the report before the rest runs and, when long, to the user with what
// would cost less. The values do not depend on the order.
constexpr double kNoteSeconds = 30.0;

std::string duration_text(double s) {
    if (s < 90.0) return fmt::format("{:.0f} s", s);
    if (s < 5400.0) return fmt::format("{:.0f} min", s / 60.0);
    return fmt::format("{:.1f} h", s / 3600.0);
}

template <class Body>
void partly_hidden_pass(std::size_t count, const MethodContext& ctx, double tol, Fields& o,
                        const Body& body) {
    const MethodOptions& options = ctx.options;
    const std::size_t stride = sample_stride(count);
    auto order = [&](std::size_t j) { return detail::strided_pair(j, count, stride); };
    const std::size_t sampled = (count + stride - 1) / stride;
    announce_phase("analytic partly hidden pairs");
    Progress progress("analytic (obstructed)", count, ctx.progress);
    const auto t0 = Clock::now();
    parallel_for(sampled, options.threads, [&](std::size_t j) {
        body(order(j));
        progress.advance();
    });
    const double sample_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    const double estimate =
        sampled > 0 ? sample_seconds * static_cast<double>(count) / static_cast<double>(sampled)
                    : 0.0;
    o["sampled_pairs"] = sampled;
    o["estimated_seconds_partly_hidden"] = estimate;
    if (ctx.progress && estimate > kNoteSeconds) {
        const int threads = effective_threads(options.threads);
        std::string text = fmt::format(
            "analytic: {} partly hidden pairs, about {} on {} thread{} (from {} of them). "
            "Less: a looser `tolerance` (now {:g}), `method` mc-hemisphere with `samples` 100000 "
            "(standard error <= 1.6e-3 per entry)",
            count, duration_text(estimate), threads, threads == 1 ? "" : "s", sampled, tol);
        if (ctx.scene.patches.size() >= 20000 && !ctx.sparse_rows)
            text += ", `output` F.h5 (sparse: only the entries that are not 0)";
        ctx.progress->note(text);
    }
    parallel_for(count - sampled, options.threads, [&](std::size_t j) {
        body(order(sampled + j));
        progress.advance();
    });
    progress.finish();
}

}  // namespace

// The partly hidden pairs given beforehand (ctx.partly_hidden), checked against the run; null
// when they are to be computed here.
static const PartlyHiddenPairs::Impl* given_pairs(const MethodContext& ctx, bool sparse) {
    if (!ctx.partly_hidden) return nullptr;
    const PartlyHiddenPairs::Impl& m = ctx.partly_hidden->impl();
    FF_ASSERT(&m.scene == &ctx.scene && m.has_values && m.sparse == sparse);
    return &m;
}

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

void AnalyticMethod::sparse_obstructed_rows(const MethodContext& ctx, double visible_tolerance,
                                            MethodResult& result) {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const double tol = checked_tolerance(options);
    const std::size_t n = scene.patches.size();
    const RowRange rows = ctx.rows.clamped(n);
    SparseRows& out = *ctx.sparse_rows;
    out.reset(rows.begin, rows.size(), false);
    FormFactors& ff = result.form_factors;
    ff.first_row = rows.begin;
    ff.F = DenseMatrix::Zero(0, static_cast<Eigen::Index>(n));
    MethodReport& report = result.report;

    const PartlyHiddenPairs::Impl* given = given_pairs(ctx, true);
    Obstructions own;
    if (!given) prepare_obstructions(ctx, true, own);
    const Obstructions& S = given ? given->S : own;
    const auto t_classified = Clock::now();
    const std::vector<ClusterTree>& trees = S.trees;
    auto touches = [&](std::size_t i, std::size_t j) {
        return rows.contains(i) || rows.contains(j);
    };
    // The unordered pairs (a < c) that touch the rows, by their first patch: every patch pair
    // of the visible node pairs, and the partly hidden ones. The others are 0: facing away,
    // fully hidden, or in one plane group (coplanar, one-sided: they do not see each other).
    std::size_t node_pairs = 0, vis = 0, hid = 0, partial_pairs = 0;
    for (const PairOutput& o : S.outputs) {
        node_pairs += o.node_pairs;
        vis += o.visible_patch_pairs;
        hid += o.hidden_patch_pairs;
        partial_pairs += o.partial.size();
    }
    {
        // Before the pair lists exist: a column, its value, a byte and (at most) two row
        // entries per pair that sees anything, ~37 bytes, and a reference to each partly
        // hidden one (8 bytes); a closed room of 10⁵ patches with a box would want ~10¹⁰ pairs.
        const double pairs = double(vis) + double(partial_pairs);
        const double need = 37.0 * pairs + 8.0 * double(partial_pairs);
        const double available = available_memory();
        if (available > 0.0 && need > available)
            throw ResourceError(fmt::format(
                "analytic sparse rows: {} pairs see each other ({} of them partly hidden), "
                "which needs about {} for the pair lists; {} is available. Use `storage` "
                "hierarchical for a closed scene, a Monte-Carlo method (mc-hemisphere) for a "
                "large open one, or a coarser subdivision",
                pairs, partial_pairs, format_bytes(need), format_bytes(available)));
    }
    std::vector<std::vector<std::int32_t>> cols(n);
    // One thread over every visible pair of a city (10⁸ of them): a signal must not wait.
    const CancellationFlag& cancel = current_cancellation();
    announce_phase("analytic pair lists");
    for (const PairOutput& o : S.outputs) {
        cancel.throw_if_requested();
        for (const NodePair& np : o.visible)
            for_each_patch_pair(trees, np, [&](std::size_t i, std::size_t j) {
                const std::size_t a = std::min(i, j), c = std::max(i, j);
                if (touches(a, c)) cols[a].push_back(static_cast<std::int32_t>(c));
            });
    }
    // The partly hidden pairs that touch the rows, as (task, place in its list): every pair of
    // every task when the rows are all of them (one process), else a list of references (8
    // bytes a pair; a copy of each pair with its places took 40).
    const std::size_t tasks = S.outputs.size();
    std::vector<std::size_t> task_first(tasks + 1, 0);  // the first pair of each task
    for (std::size_t t = 0; t < tasks; ++t)
        task_first[t + 1] = task_first[t] + S.outputs[t].partial.size();
    const bool every_pair = rows.begin == 0 && rows.end >= n;
    struct PairRef {
        std::uint32_t task, at;
    };
    std::vector<PairRef> refs;
    for (std::size_t t = 0; t < tasks; ++t) {
        const std::vector<PartialPair>& list = S.outputs[t].partial;
        FF_ASSERT(list.size() <= UINT32_MAX && t <= UINT32_MAX);
        for (std::size_t k = 0; k < list.size(); ++k) {
            const auto i = static_cast<std::size_t>(list[k].i);
            const auto j = static_cast<std::size_t>(list[k].j);
            if (!touches(i, j)) continue;
            if (!every_pair)
                refs.push_back({static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(k)});
            cols[std::min(i, j)].push_back(static_cast<std::int32_t>(std::max(i, j)));
        }
    }
    const std::size_t partial_count = every_pair ? task_first[tasks] : refs.size();
    // Pair k of the pass: its task and its place in the task's list.
    auto pair_ref = [&](std::size_t k) -> PairRef {
        if (!every_pair) return refs[k];
        const auto t = static_cast<std::size_t>(
            std::upper_bound(task_first.begin(), task_first.end(), k) - task_first.begin() - 1);
        return {static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(k - task_first[t])};
    };
    // Sorted, and no room beyond their size (their growth leaves up to as much again).
    parallel_for(n, options.threads, [&](std::size_t a) {
        std::sort(cols[a].begin(), cols[a].end());
        cols[a].shrink_to_fit();
    });
    // Their exact unobstructed values U_ac (the dense matrix's, bit for bit).
    std::vector<const Polygon*> polys(n);
    for (std::size_t p = 0; p < n; ++p) polys[p] = &scene.patches[p].polygon;
    std::vector<std::vector<double>> upper;
    announce_phase("analytic visible pairs");
    Progress unobs_progress("analytic (visible pairs)", n, ctx.progress);
    const detail::UnobstructedStats ust =
        detail::unobstructed_pairs(polys, visible_tolerance, options.threads, &unobs_progress, cols,
                                   upper, ff.areas, given ? given->table.get() : nullptr);
    unobs_progress.finish();
    const std::vector<double>& areas = ff.areas;
    // One value a pair: U_ac or, once integrated, the partly hidden pair's F_sr; `lower_held`
    // marks the slots whose value is the lower entry F_ca (s = c). The other entry of a slot is
    // its reciprocal (reciprocal_entry(), as PartialValue::back: bit for bit the dense matrix's).
    std::vector<std::vector<std::uint8_t>> lower_held(n);
    parallel_for(n, options.threads,
                 [&](std::size_t a) { lower_held[a].assign(cols[a].size(), 0); });
    auto slot = [&](std::size_t a, std::size_t c) {
        const auto at =
            std::lower_bound(cols[a].begin(), cols[a].end(), static_cast<std::int32_t>(c));
        FF_ASSERT(at != cols[a].end() && *at == static_cast<std::int32_t>(c));
        return static_cast<std::size_t>(at - cols[a].begin());
    };
    // F_ac (a < c: the upper entry) and F_ca of slot k of row a.
    auto upper_entry = [&](std::size_t a, std::size_t k) {
        const double v = upper[a][k];
        if (!lower_held[a][k]) return v;
        return detail::reciprocal_entry(v, areas[static_cast<std::size_t>(cols[a][k])], areas[a]);
    };
    auto lower_entry = [&](std::size_t a, std::size_t k) {
        const double v = upper[a][k];
        if (lower_held[a][k]) return v;
        return detail::reciprocal_entry(v, areas[a], areas[static_cast<std::size_t>(cols[a][k])]);
    };
    // The partly hidden pairs: the unobstructed value less the integrated hidden part, as the
    // dense pass computes it, written into the pair's slot as it comes (each unordered pair is
    // listed once, so no two threads write the same slot; a list of the values would hold ~100
    // bytes per pair, more than the pairs' lists, at the peak).
    ThreadStats stats;
    auto store = [&](const PartialValue& v) {
        if (!v.integrated) return;
        const std::size_t a = std::min(v.s, v.r), c = std::max(v.s, v.r);
        const std::size_t k = slot(a, c);
        upper[a][k] = v.f;
        lower_held[a][k] = v.s > v.r ? 1 : 0;
    };
    Fields& obs = report.details["obstructions"];
    if (given) {
        parallel_for(partial_count, options.threads, [&](std::size_t k) {
            const PairRef p = pair_ref(k);
            store(given->value(task_first[p.task] + p.at));
        });
    } else {
        partly_hidden_pass(partial_count, ctx, tol, obs, [&](std::size_t k) {
            const PairRef p = pair_ref(k);
            const PairOutput& o = S.outputs[p.task];
            const PartialValue v = integrate_partial(
                scene, S, o.partial[p.at], o.cand, tol, [&](std::size_t s, std::size_t r) {
                    return s < r ? upper_entry(s, slot(s, r)) : lower_entry(r, slot(r, s));
                });
            add_pair(stats.local(), v.stats);
            store(v);
        });
    }
    // The classification's lists (the candidates of every partly hidden pair) are done with
    // before the rows are built.
    std::vector<PairRef>().swap(refs);
    if (!given) std::vector<PairOutput>().swap(own.outputs);
    const auto t_done = Clock::now();
    // The rows: entries F_ic (c > i) from row i's pairs, F_ia (a < i) from the pairs (a, i),
    // columns ascending, zeros left out. Each row's room counted first; the pairs of patch a are
    // freed once its entries are out, so that the lists and the rows do not both peak.
    announce_phase("analytic rows");
    // emit(row, column, value) for the nonzero entries of patch a's pairs in the rows: row a's
    // own (F_ac, c > a, ascending), then F_ca into the later rows c (they come after the
    // entries of the patches before a, so every row's columns ascend).
    auto each_entry = [&](std::size_t a, const auto& emit) {
        if (rows.contains(a))
            for (std::size_t k = 0; k < cols[a].size(); ++k) {
                const double u = upper_entry(a, k);
                if (u > 0.0) emit(a - rows.begin, cols[a][k], u);
            }
        for (std::size_t k = 0; k < cols[a].size(); ++k) {
            const auto c = static_cast<std::size_t>(cols[a][k]);
            if (!rows.contains(c)) continue;
            const double l = lower_entry(a, k);
            if (l > 0.0) emit(c - rows.begin, static_cast<std::int32_t>(a), l);
        }
    };
    std::vector<std::size_t> row_size(rows.size(), 0);
    for (std::size_t a = 0; a < n; ++a) {
        cancel.throw_if_requested();
        each_entry(a, [&](std::size_t row, std::int32_t, double) { ++row_size[row]; });
    }
    for (std::size_t row = 0; row < rows.size(); ++row) {
        out.indices[row].reserve(row_size[row]);
        out.values[row].reserve(row_size[row]);
    }
    for (std::size_t a = 0; a < n; ++a) {
        cancel.throw_if_requested();
        each_entry(a, [&](std::size_t row, std::int32_t col, double v) {
            out.indices[row].push_back(col);
            out.values[row].push_back(v);
        });
        std::vector<std::int32_t>().swap(cols[a]);
        std::vector<double>().swap(upper[a]);
        std::vector<std::uint8_t>().swap(lower_held[a]);
    }

    report.pairs = PairClasses{ust.zero + ust.exact + ust.far, ust.zero, ust.exact, ust.far};
    Fields& details = report.details;
    details["tolerance"] = visible_tolerance;
    details["threads"] = effective_threads(options.threads);
    details["obstructed"] = true;
    details["sparse_rows"] = true;
    details["far_field_kernel_evaluations"] = ust.points;
    details["unobstructed_pairs_computed"] = ust.zero + ust.exact + ust.far;
    Fields& o = details["obstructions"];
    report_obstructions(S, given ? given->values.stats : combined(stats), node_pairs, vis, hid,
                        given ? given->partial.size() : partial_count, tol,
                        effective_threads(options.threads), o);
    o["seconds_partly_hidden"] = seconds(t_classified, t_done);
    report.error_bound_per_entry =
        std::max(std::max(visible_tolerance, 1e-12), o["max_error_estimate"].real());
    details["exact_path_error"] = 1e-12;
}

}  // namespace formfactor
