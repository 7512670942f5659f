// The settling of one partly hidden pair by the `analytic` method, apart from
// integrate_partial() (partial_pair.h): the tolerance it is settled to, the sender cut into
// quarters for a tighter bound from the umbrae of its occluders (the conservative visibility
// bounds of Lischinski, Smits & Greenberg 1994, umbrae.cpp), and what the settling of the pairs
// did, summed (PartlyHiddenStats) and reported in details["obstructions"]. See docs/analytic.md,
// "Obstructed scenes".

#include "methods/analytic/partial_pair.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "formfactor/core/error.h"

namespace formfactor {

namespace detail {

double checked_tolerance(const MethodOptions& options) {
    const double tol = options.obstructed_tolerance;
    if (!(tol > 0.0) || !std::isfinite(tol))
        throw OptionError("tolerance", "must be a positive number (absolute error per entry)");
    return tol;
}

PartialStats combined(ThreadStats& per_thread) {
    PartialStats total;
    for (const PartialStats& s : per_thread) total.add(s);
    return total;
}

// The sender cut into four: a triangle at its edges' midpoints, a quad at its edges' midpoints
// and its centre (the other polygons whole).
std::vector<Polygon> quarters(const Polygon& p) {
    const std::size_t n = p.size();
    if (n != 3 && n != 4) return {p};
    std::vector<Polygon> out(4);
    auto mid = [&](std::size_t a) { return 0.5 * (p[a] + p[(a + 1) % n]); };
    if (n == 3) {
        out[0].vertices = {p[0], mid(0), mid(2)};
        out[1].vertices = {mid(0), p[1], mid(1)};
        out[2].vertices = {mid(2), mid(1), p[2]};
        out[3].vertices = {mid(0), mid(1), mid(2)};
        return out;
    }
    const Vec3 c = 0.25 * (p[0] + p[1] + p[2] + p[3]);
    for (std::size_t k = 0; k < 4; ++k) out[k].vertices = {p[k], mid(k), c, mid((k + 3) % 4)};
    return out;
}

int unoccluded_candidates(const BlockerSet& blockers, const Polygon& s, const Polygon& r,
                          const int* cand, int n, std::vector<int>& out) {
    out.assign(cand, cand + n);
    thread_local std::vector<int> solids;
    solids.clear();
    for (int c = 0; c < n; ++c) {
        const int so = blockers.piece(cand[c]).solid;
        if (so >= 0 && std::find(solids.begin(), solids.end(), so) == solids.end())
            solids.push_back(so);
    }
    if (solids.empty() || n < 2) return n;
    // Per solid of the list: a piece of it left out (0/1), and whether it hides a piece left
    // out from r's side (then none of its pieces may go).
    thread_local std::vector<char> lost, hider;
    lost.assign(solids.size(), 0);
    hider.assign(solids.size(), 0);
    auto index_of = [&](int so) {
        return so < 0
                   ? -1
                   : static_cast<int>(std::find(solids.begin(), solids.end(), so) - solids.begin());
    };
    thread_local std::vector<char> hidden;
    hidden.assign(static_cast<std::size_t>(n), 0);
    // From s: every piece that a solid of another piece hides (the chains end, each step
    // nearer s).
    const int ns = static_cast<int>(s.size());
    for (int c = 0; c < n; ++c) {
        const auto& pc = blockers.piece(cand[c]);
        const Vec3* pv = blockers.vertices(cand[c]);
        for (std::size_t k = 0; k < solids.size(); ++k)
            if (solids[k] != pc.solid &&
                blockers.solid_hides(solids[k], s.vertices.data(), ns, pv, pc.count)) {
                hidden[static_cast<std::size_t>(c)] = 1;
                if (const int own = index_of(pc.solid); own >= 0)
                    lost[static_cast<std::size_t>(own)] = 1;
                break;
            }
    }
    // From r: a piece that a solid hides which keeps all its pieces, which it then must.
    const int nr = static_cast<int>(r.size());
    for (int c = 0; c < n; ++c) {
        if (hidden[static_cast<std::size_t>(c)]) continue;
        const auto& pc = blockers.piece(cand[c]);
        const int own = index_of(pc.solid);
        if (own >= 0 && hider[static_cast<std::size_t>(own)]) continue;
        const Vec3* pv = blockers.vertices(cand[c]);
        for (std::size_t k = 0; k < solids.size(); ++k)
            if (solids[k] != pc.solid && !lost[k] &&
                blockers.solid_hides(solids[k], r.vertices.data(), nr, pv, pc.count)) {
                hidden[static_cast<std::size_t>(c)] = 1;
                hider[k] = 1;
                if (own >= 0) lost[static_cast<std::size_t>(own)] = 1;
                break;
            }
    }
    out.clear();
    for (int c = 0; c < n; ++c)
        if (!hidden[static_cast<std::size_t>(c)]) out.push_back(cand[c]);
    return static_cast<int>(out.size());
}

// details["obstructions"] (docs/analytic.md): the blockers, the pair classes, the integration.
void report_obstructions(const Obstructions& S, const PartialStats& total, std::size_t node_pairs,
                         std::size_t visible, std::size_t hidden, std::size_t partial, double tol,
                         int threads, Fields& o) {
    Fields levels = Fields::object();
    for (int l = 0; l <= kLevels; ++l)
        if (total.levels[static_cast<std::size_t>(l)] > 0)
            levels[std::to_string(l)] = total.levels[static_cast<std::size_t>(l)];
    o["blocker_pieces"] = S.blockers.size();
    o["plane_groups"] = S.trees.size();
    o["obstruction_plane_groups"] = S.otrees.size();
    o["merged_blocker_pieces"] = S.merged_pieces;
    o["one_sided_plane_groups"] = S.one_sided_groups;
    o["node_pairs_tested"] = node_pairs;
    o["patch_pairs_visible"] = visible;
    o["patch_pairs_hidden"] = hidden;
    o["patch_pairs_partly_hidden"] = partial;
    o["partly_hidden_pairs_changed"] = total.changed;
    o["refinement_levels"] = levels;
    o["cells"] = total.cells;
    o["point_evaluations"] = total.points;
    o["umbra_cells"] = total.closed_forms;
    o["umbra_cells_proven_by_corners"] = total.proven_hidden;
    o["cells_bracketed"] = total.cells_bracketed;
    o["capped_pairs"] = total.capped;
    o["partly_hidden_pairs_bracketed"] = total.bracketed;
    o["partly_hidden_pairs_settled_by_umbrae"] = total.settled_by_umbrae;
    o["partly_hidden_pairs_cut_budget_spent"] = total.cut_budget_spent;
    o["occluded_candidates"] = total.occluded_candidates;
    o["partly_hidden_pairs_over_seeing_parts"] = total.integrated_over_seeing_parts;
    o["tolerance"] = tol;
    o["max_error_estimate"] = total.max_error;
    o["threads"] = threads;
    o["seconds_setup"] = S.seconds_setup;
    o["seconds_classification"] = S.seconds_classification;
}

}  // namespace detail

void PartlyHiddenStats::add(const PartlyHiddenStats& o) {
    for (std::size_t l = 0; l < levels.size(); ++l) levels[l] += o.levels[l];
    max_error = std::max(max_error, o.max_error);
    points += o.points;
    cells += o.cells;
    closed_forms += o.closed_forms;
    proven_hidden += o.proven_hidden;
    cells_bracketed += o.cells_bracketed;
    capped += o.capped;
    changed += o.changed;
    bracketed += o.bracketed;
    settled_by_umbrae += o.settled_by_umbrae;
    cut_budget_spent += o.cut_budget_spent;
    occluded_candidates += o.occluded_candidates;
    integrated_over_seeing_parts += o.integrated_over_seeing_parts;
}

}  // namespace formfactor
