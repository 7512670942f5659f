// The sparse rows of the `analytic` method in an obstructed scene: the classification's tasks
// (pairs of plane groups, classification.cpp) in blocks, each block's partly hidden pairs settled
// by integrate_partial() (partial_pair.h) before the next block is classified, then the rows
// from the visible pairs' exact values and the partly hidden pairs' kept values. See
// docs/analytic.md, "Sparse rows in blocks".

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <memory>
#include <numeric>
#include <optional>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/core/progress.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/partly_hidden.h"
#include "kernels/unobstructed.h"
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
using detail::PartialValue;
using detail::report_obstructions;
using detail::sampled_pass;
using detail::seconds;
using detail::ThreadStats;

// The sparse rows classify the tasks (pairs of plane groups) in blocks and settle each block's
// partly hidden pairs before the next block is classified, so that the pairs' candidate lists are
// never all held at once (the 9,946-triangle urban array has 3.13 M such pairs, 12 bytes and a
// list of ~15 bytes each). Each block takes one task of every round of K tasks by size, so that
// it is a sample of the whole: the first block's time, scaled, is the estimate before the rest
// runs. K: one block per kTasksPerBlock tasks, at most kMaxBlocks (a small scene is one block).
constexpr std::size_t kTasksPerBlock = 64;
constexpr std::size_t kMaxBlocks = 16;

void add_stats(detail::UnobstructedStats& total, const detail::UnobstructedStats& s) {
    total.zero += s.zero;
    total.exact += s.exact;
    total.far += s.far;
    total.points += s.points;
    for (std::size_t k = 0; k < s.order_hist.size(); ++k) total.order_hist[k] += s.order_hist[k];
}

// A partly hidden pair (a < c) kept with its value F_sr as its slot's: bit 31 of `c` set when
// the value is the lower entry F_ca (s = c).
struct Valued {
    std::uint32_t a, c;
    double f;
};
static_assert(sizeof(Valued) == 16);
constexpr std::uint32_t kLower = 1u << 31;

// Row a's kept partly hidden pairs [first, last) merged into its visible pairs' columns `cols`
// (ascending) and values `upper`; `lower` gets which slots hold the lower entry. Visible pairs
// whose value is 0 are left out, as the rows leave out their entries (pairs facing away are
// left out of the lists before; a pair that straddles a plane may still come out 0).
void merge_row(std::vector<std::int32_t>& cols, std::vector<double>& upper,
               std::vector<std::uint8_t>& lower, Valued* first, Valued* last) {
    std::sort(first, last,
              [](const Valued& x, const Valued& y) { return (x.c & ~kLower) < (y.c & ~kLower); });
    const auto seen = static_cast<std::size_t>(
        std::count_if(upper.begin(), upper.end(), [](double u) { return u > 0.0; }));
    const std::size_t m = seen + static_cast<std::size_t>(last - first);
    std::vector<std::int32_t> c2;
    std::vector<double> u2;
    std::vector<std::uint8_t> l2;
    c2.reserve(m);
    u2.reserve(m);
    l2.reserve(m);
    std::size_t k = 0;
    auto visible_up_to = [&](std::int64_t c) {
        for (; k < cols.size() && cols[k] < c; ++k) {
            if (!(upper[k] > 0.0)) continue;
            c2.push_back(cols[k]);
            u2.push_back(upper[k]);
            l2.push_back(0);
        }
    };
    for (const Valued* it = first; it != last; ++it) {
        const auto c = static_cast<std::int32_t>(it->c & ~kLower);
        visible_up_to(c);
        FF_ASSERT(k == cols.size() || cols[k] != c);  // a pair is visible or partly hidden
        c2.push_back(c);
        u2.push_back(it->f);
        l2.push_back((it->c & kLower) != 0 ? 1 : 0);
    }
    visible_up_to(INT64_MAX);
    cols.swap(c2);
    upper.swap(u2);
    lower.swap(l2);
}

}  // namespace

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
    const CancellationFlag& cancel = current_cancellation();

    const PartlyHiddenPairs::Impl* given = given_pairs(ctx, true);
    Obstructions own;
    if (!given) prepare_blockers(ctx, own);
    const Obstructions& S = given ? given->S : own;
    const std::vector<ClusterTree>& trees = S.trees;
    auto touches = [&](std::size_t i, std::size_t j) {
        return rows.contains(i) || rows.contains(j);
    };
    std::vector<const Polygon*> polys(n);
    for (std::size_t p = 0; p < n; ++p) polys[p] = &scene.patches[p].polygon;
    // The patches' table of the unobstructed values, built once for every block and the rows.
    std::shared_ptr<const detail::PatchTable> own_table;
    const detail::PatchTable* table = given ? given->table.get() : nullptr;
    if (!table) {
        own_table = detail::make_patch_table(polys, options.threads);
        table = own_table.get();
    }
    // Pairs facing away (a patch behind the other's plane) are 0 by the test every unobstructed
    // path applies first: neither the estimate nor the pair lists below hold them.
    const double eps_facing = detail::facing_eps(polys);
    auto faces_away = [&](std::size_t a, std::size_t c) {
        return detail::faces_away(*table, polys, a, c, eps_facing);
    };
    std::vector<double> areas;

    // The tasks in blocks (given pairs: their classification is done, one block).
    const std::size_t tasks = given ? S.outputs.size() : detail::classification_tasks(S);
    const std::size_t blocks =
        given ? 1 : std::clamp<std::size_t>(tasks / kTasksPerBlock, 1, kMaxBlocks);
    std::vector<std::size_t> order(tasks);
    if (blocks > 1) {
        order = detail::tasks_by_size(S);
    } else {
        std::iota(order.begin(), order.end(), std::size_t{0});
    }
    // Given pairs: the place of each task's first pair in their list.
    std::vector<std::size_t> task_first;
    if (given) {
        task_first.assign(tasks + 1, 0);
        for (std::size_t t = 0; t < tasks; ++t)
            task_first[t + 1] = task_first[t] + S.outputs[t].partial.size();
    }

    // What the blocks leave: the visible node pairs, and the partly hidden pairs whose value is
    // above 0 (a pair that ends at 0 needs no slot: its entries are left out).
    std::vector<std::vector<NodePair>> visible_of(blocks);
    std::vector<std::vector<Valued>> valued_of(blocks);
    std::size_t node_pairs = 0, vis = 0, hid = 0, partial_pairs = 0, partial_count = 0;
    detail::UnobstructedStats ust;
    ThreadStats stats;
    Fields& obs = report.details["obstructions"];
    double seconds_classification = 0.0, seconds_pass = 0.0;
    std::optional<Progress> progress;
    std::size_t expected = 0;  // the pairs the progress counts: blocks × the first block's

    for (std::size_t b = 0; b < blocks; ++b) {
        cancel.throw_if_requested();
        std::vector<std::size_t> list;
        // Rounds of `blocks` tasks, the block's place in each round alternating from either
        // end, so that no block takes the largest task of every round.
        for (std::size_t round = 0; round * blocks < tasks; ++round) {
            const std::size_t q = round * blocks + (round % 2 == 0 ? b : blocks - 1 - b);
            if (q < tasks) list.push_back(order[q]);
        }
        std::vector<PairOutput> fresh;
        const auto t_class = Clock::now();
        if (!given) {
            announce_phase("analytic classification");
            fresh.resize(list.size());
            detail::classify_task_list(S, list.data(), list.size(), true, options.threads,
                                       fresh.data());
        }
        const double block_class = seconds(t_class, Clock::now());
        seconds_classification += block_class;
        auto output = [&](std::size_t q) -> const PairOutput& {
            return given ? S.outputs[list[q]] : fresh[q];
        };
        // The block's partly hidden pairs that touch the rows, as (task, place in its list).
        struct PairRef {
            std::uint32_t q, at;
        };
        std::vector<PairRef> refs;
        std::vector<std::vector<std::int32_t>> cols(n);
        for (std::size_t q = 0; q < list.size(); ++q) {
            const PairOutput& o = output(q);
            node_pairs += o.node_pairs;
            vis += o.visible_patch_pairs;
            hid += o.hidden_patch_pairs;
            partial_pairs += o.partial.size();
            visible_of[b].insert(visible_of[b].end(), o.visible.begin(), o.visible.end());
            FF_ASSERT(o.partial.size() <= UINT32_MAX && q <= UINT32_MAX);
            for (std::size_t k = 0; k < o.partial.size(); ++k) {
                const auto i = static_cast<std::size_t>(o.partial[k].i);
                const auto j = static_cast<std::size_t>(o.partial[k].j);
                if (!touches(i, j)) continue;
                refs.push_back({static_cast<std::uint32_t>(q), static_cast<std::uint32_t>(k)});
                cols[std::min(i, j)].push_back(static_cast<std::int32_t>(std::max(i, j)));
            }
        }
        visible_of[b].shrink_to_fit();
        if (b == 0) {
            // Before the pair lists exist: a column, its value, a byte and (at most) two row
            // entries per pair that sees anything, ~37 bytes, and 16 bytes for the value of each
            // partly hidden one; a closed room of 10⁵ patches with a box would want ~10¹⁰
            // pairs. From the first block, a sample of the tasks. The visible pairs that face
            // away (never held, see the pair lists below) are not counted: in an open city they
            // are a third of them.
            std::size_t vis_facing = 0;
            for (const NodePair& np : visible_of[b])
                for_each_patch_pair(trees, np, [&](std::size_t i, std::size_t j) {
                    const std::size_t a = std::min(i, j), c = std::max(i, j);
                    if (touches(a, c) && !faces_away(a, c)) ++vis_facing;
                });
            const double scale = static_cast<double>(tasks) / static_cast<double>(list.size());
            const double pairs = scale * (double(vis_facing) + double(refs.size()));
            const double need = 37.0 * pairs + 16.0 * scale * double(refs.size());
            const double available = available_memory();
            if (available > 0.0 && need > available)
                throw ResourceError(fmt::format(
                    "analytic sparse rows: {}{:.0f} pairs see each other ({:.0f} of them partly "
                    "hidden), which needs about {} for the pair lists; {} is available. Use "
                    "`storage` hierarchical for a closed scene, a Monte-Carlo method "
                    "(mc-hemisphere) for a large open one, or a coarser subdivision",
                    blocks > 1 ? "about " : "", pairs, scale * double(refs.size()),
                    format_bytes(need), format_bytes(available)));
            expected = blocks * refs.size();
            if (!given) progress.emplace("analytic (obstructed)", expected, ctx.progress);
        }
        partial_count += refs.size();
        // Their exact unobstructed values U_ac (bit for bit the rows' below).
        parallel_for(n, options.threads,
                     [&](std::size_t a) { std::sort(cols[a].begin(), cols[a].end()); });
        std::vector<std::vector<double>> upper;
        const detail::UnobstructedStats bu = detail::unobstructed_pairs(
            polys, visible_tolerance, options.threads, nullptr, cols, upper, areas, table);
        add_stats(ust, bu);
        auto unobstructed = [&](std::size_t s, std::size_t r) {
            const std::size_t a = std::min(s, r), c = std::max(s, r);
            const auto at =
                std::lower_bound(cols[a].begin(), cols[a].end(), static_cast<std::int32_t>(c));
            FF_ASSERT(at != cols[a].end() && *at == static_cast<std::int32_t>(c));
            const double u = upper[a][static_cast<std::size_t>(at - cols[a].begin())];
            return s < r ? u : detail::reciprocal_entry(u, areas[r], areas[s]);
        };
        // The pairs' values as they come (f = 0: nothing to keep); those above 0 are kept.
        std::vector<Valued> values(refs.size(), Valued{0, 0, 0.0});
        const auto t_pass = Clock::now();
        // Progress: each block counts as the first block's share of `expected`.
        std::atomic<std::size_t> done{0};
        const std::size_t share = expected / blocks, here = refs.size();
        auto advance = [&]() {
            const std::size_t k = ++done;
            if (here == 0 || !progress) return;
            progress->advance(k * share / here - (k - 1) * share / here);
        };
        auto body = [&](std::size_t k) {
            const PairRef p = refs[k];
            const PairOutput& o = output(p.q);
            PartialValue v;
            if (given) {
                v = given->value(task_first[list[p.q]] + p.at);
            } else {
                v = integrate_partial(scene, S, o.partial[p.at], o.cand, tol, unobstructed);
                add_pair(stats.local(), v.stats);
            }
            if (!v.integrated || !(v.f > 0.0)) return;
            values[k] = {static_cast<std::uint32_t>(std::min(v.s, v.r)),
                         static_cast<std::uint32_t>(std::max(v.s, v.r)) | (v.s > v.r ? kLower : 0u),
                         v.f};
        };
        if (given) {
            parallel_for(refs.size(), options.threads, [&](std::size_t k) {
                body(k);
                advance();
            });
        } else if (b == 0) {
            // The first block's pass starts with a sample of its pairs, the estimate of the
            // whole pass (and of the later blocks' classification).
            sampled_pass(refs.size(), expected, block_class * double(blocks - 1), ctx, tol, obs,
                         *progress, body);
        } else {
            announce_phase("analytic partly hidden pairs");
            parallel_for(refs.size(), options.threads, [&](std::size_t k) {
                body(k);
                advance();
            });
        }
        seconds_pass += seconds(t_pass, Clock::now());
        std::vector<Valued>& kept = valued_of[b];
        kept.reserve(static_cast<std::size_t>(std::count_if(
            values.begin(), values.end(), [](const Valued& v) { return v.f > 0.0; })));
        for (const Valued& v : values)
            if (v.f > 0.0) kept.push_back(v);
    }
    if (given) partial_count = given->partial.size();
    if (progress) progress->finish();
    if (!given) own.seconds_classification = seconds_classification;
    obs["seconds_partly_hidden"] = seconds_pass;

    // The pairs that see anything and touch the rows, by their first patch a (a < c): every
    // patch pair of the visible node pairs, then the kept partly hidden ones merged in. The
    // others are 0: facing away, fully hidden, in one plane group (coplanar, one-sided), or
    // partly hidden pairs that ended at 0.
    // The freed pages back to the system (the classification's last block: on the
    // 9,946-triangle urban array the pair lists' phase starts 19 MB below the pass's peak); so
    // too after the kept values are merged and after the rows are made.
    release_free_memory();
    // Pairs facing away (a patch behind the other's plane: ground triangles and the walls
    // behind them) are left out here, by the test that gives them U = 0 below: on the
    // 9,946-triangle urban array 1.97 M of the 5.73 M pairs the rows consider, whose columns and
    // values were the peak's last 25 MB. They count among the pairs found zero.
    std::vector<std::vector<std::int32_t>> cols(n);
    std::size_t faced_away = 0;
    announce_phase("analytic pair lists");
    {
        for (std::vector<NodePair>& list : visible_of) {
            cancel.throw_if_requested();
            for (const NodePair& np : list)
                for_each_patch_pair(trees, np, [&](std::size_t i, std::size_t j) {
                    const std::size_t a = std::min(i, j), c = std::max(i, j);
                    if (!touches(a, c)) return;
                    if (faces_away(a, c)) {
                        ++faced_away;
                        return;
                    }
                    cols[a].push_back(static_cast<std::int32_t>(c));
                });
            std::vector<NodePair>().swap(list);
        }
    }
    // Sorted, and no room beyond their size (their growth leaves up to as much again).
    parallel_for(n, options.threads, [&](std::size_t a) {
        std::sort(cols[a].begin(), cols[a].end());
        cols[a].shrink_to_fit();
    });
    // Their exact unobstructed values U_ac (the dense matrix's, bit for bit).
    std::vector<std::vector<double>> upper;
    announce_phase("analytic visible pairs");
    Progress unobs_progress("analytic (visible pairs)", n, ctx.progress);
    const detail::UnobstructedStats vu = detail::unobstructed_pairs(
        polys, visible_tolerance, options.threads, &unobs_progress, cols, upper, ff.areas, table);
    unobs_progress.finish();
    // The table's last use: not held beside the rows (10 MB on a 9,946-triangle urban array).
    table = nullptr;
    own_table.reset();
    add_stats(ust, vu);
    ust.zero += faced_away;
    const std::vector<double>& pa = ff.areas;
    // One value a pair: U_ac or a partly hidden pair's F_sr; `lower_held` marks the slots whose
    // value is the lower entry F_ca (s = c). The other entry of a slot is its reciprocal
    // (reciprocal_entry(), as PartialValue::back: bit for bit the dense matrix's).
    std::vector<std::vector<std::uint8_t>> lower_held(n);
    {
        // The kept partly hidden pairs by row, merged into the visible ones' columns.
        std::vector<std::size_t> row_first(n + 1, 0);
        for (const auto& kept : valued_of)
            for (const Valued& v : kept) ++row_first[v.a + 1];
        for (std::size_t a = 0; a < n; ++a) row_first[a + 1] += row_first[a];
        std::vector<Valued> by_row(row_first[n]);
        {
            std::vector<std::size_t> at(row_first.begin(), row_first.end() - 1);
            for (auto& kept : valued_of) {
                for (const Valued& v : kept) by_row[at[v.a]++] = v;
                std::vector<Valued>().swap(kept);
            }
        }
        parallel_for(n, options.threads, [&](std::size_t a) {
            merge_row(cols[a], upper[a], lower_held[a], by_row.data() + row_first[a],
                      by_row.data() + row_first[a + 1]);
        });
    }
    release_free_memory();  // the kept values by row and the pair lists they were merged into
    // The rows: entries F_ic (c > i) from row i's pairs, F_ia (a < i) from the pairs (a, i),
    // columns ascending, zeros left out. The pairs of a row in the range move into the row's own
    // arrays, after room for its entries below the diagonal (pairs (a, i), a < i), so that the
    // pair lists and the rows are not both held: 12 bytes an entry and 1 a pair (lower_held)
    // instead of 13 more for each pair beside the rows.
    announce_phase("analytic rows");
    std::vector<std::size_t> below(rows.size(), 0);
    for (std::size_t a = 0; a < n; ++a)
        for (const std::int32_t c : cols[a])
            if (rows.contains(static_cast<std::size_t>(c)))
                ++below[static_cast<std::size_t>(c) - rows.begin];
    parallel_for(rows.size(), options.threads, [&](std::size_t row) {
        const std::size_t a = rows.begin + row, m = below[row] + cols[a].size();
        out.indices[row].resize(m);
        out.values[row].resize(m);
        std::copy(cols[a].begin(), cols[a].end(), out.indices[row].begin() + below[row]);
        std::copy(upper[a].begin(), upper[a].end(), out.values[row].begin() + below[row]);
        std::vector<std::int32_t>().swap(cols[a]);
        std::vector<double>().swap(upper[a]);
    });
    // Patch a's pairs in increasing a: F_ca into row c at its next place below the diagonal
    // (the patches before a have filled theirs: the columns ascend), and F_ac in place of the
    // value held. The value held is F_ac, or F_ca where lower_held says so; the other entry is
    // its reciprocal (reciprocal_entry(), as PartialValue::back: bit for bit the dense
    // matrix's).
    std::vector<std::size_t> filled(rows.size(), 0);
    for (std::size_t a = 0; a < n; ++a) {
        if (a % 1024 == 0) cancel.throw_if_requested();
        const bool in_range = rows.contains(a);
        const std::int32_t* c_of =
            in_range ? out.indices[a - rows.begin].data() + below[a - rows.begin] : cols[a].data();
        double* v_of =
            in_range ? out.values[a - rows.begin].data() + below[a - rows.begin] : upper[a].data();
        const std::vector<std::uint8_t>& held = lower_held[a];
        for (std::size_t k = 0; k < held.size(); ++k) {
            const auto c = static_cast<std::size_t>(c_of[k]);
            const double v = v_of[k];
            if (rows.contains(c)) {
                const std::size_t row = c - rows.begin, at = filled[row]++;
                out.indices[row][at] = static_cast<std::int32_t>(a);
                out.values[row][at] = held[k] ? v : detail::reciprocal_entry(v, pa[a], pa[c]);
            }
            if (held[k]) v_of[k] = detail::reciprocal_entry(v, pa[c], pa[a]);
        }
        std::vector<std::uint8_t>().swap(lower_held[a]);
        std::vector<std::int32_t>().swap(cols[a]);
        std::vector<double>().swap(upper[a]);
    }
    release_free_memory();  // the pair lists, moved into the rows
    // Entries that came out 0 (a reciprocal below the smallest double) are left out.
    parallel_for(rows.size(), options.threads, [&](std::size_t row) {
        std::vector<std::int32_t>& idx = out.indices[row];
        std::vector<double>& val = out.values[row];
        std::size_t kept = 0;
        for (std::size_t k = 0; k < val.size(); ++k)
            if (val[k] > 0.0) {
                idx[kept] = idx[k];
                val[kept++] = val[k];
            }
        idx.resize(kept);
        val.resize(kept);
    });

    report.pairs = PairClasses{ust.zero + ust.exact + ust.far, ust.zero, ust.exact, ust.far};
    Fields& details = report.details;
    details["tolerance"] = visible_tolerance;
    details["threads"] = effective_threads(options.threads);
    details["obstructed"] = true;
    details["sparse_rows"] = true;
    details["far_field_kernel_evaluations"] = ust.points;
    details["unobstructed_pairs_computed"] = ust.zero + ust.exact + ust.far;
    // (A reference into details does not outlive an insertion into it.)
    Fields& o = details["obstructions"];
    report_obstructions(S, given ? given->values.stats : combined(stats), node_pairs, vis, hid,
                        partial_count, tol, effective_threads(options.threads), o);
    o["classification_blocks"] = blocks;
    report.error_bound_per_entry =
        std::max(std::max(visible_tolerance, 1e-12), o["max_error_estimate"].real());
    details["exact_path_error"] = 1e-12;
}

}  // namespace formfactor
