#pragma once
// The settling of one partly hidden pair by the `analytic` method (not public API). After the
// classification of patch pairs (classification.cpp), every partly hidden pair is settled, the
// cheapest way that meets the tolerance first: its bracket [0, unobstructed], the umbrae of its
// occluders (umbrae.cpp: the conservative visibility bounds of Lischinski, Smits & Greenberg
// 1994), or the adaptive integration of its hidden part (hidden_integral.cpp: Walton's adaptive
// method, NISTIR 6925). integrate_partial() is the one code path of the dense matrix, a block of
// rows and sparse rows (analytic_obstructed.cpp) and of the partly hidden pairs computed apart
// from the rows (partly_hidden_pairs.cpp); partial_pair.cpp holds the rest: the sender's
// quarters, and the statistics of the pairs summed and reported. See docs/analytic.md,
// "Obstructed scenes".

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/fields.h"
#include "formfactor/core/random.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/partly_hidden.h"
#include "formfactor/scene/scene.h"
#include "methods/analytic/classification.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor::detail {

// options.obstructed_tolerance, the absolute error per entry of the partly hidden pairs; an
// OptionError unless it is a positive number.
double checked_tolerance(const MethodOptions& options);

// What the integration of one partly hidden pair did (small: room n = 32 has 800k such pairs).
struct PairStats {
    double error = 0;
    std::size_t points = 0, cells = 0, closed_forms = 0, proven_hidden = 0, cells_bracketed = 0,
                occluded = 0;
    int level = 0, capped = 0;
    bool integrated = false, changed = false, bracketed = false, settled_by_umbrae = false,
         budget_spent = false, seeing_parts = false;
};

// What an integration (HiddenIntegral, SeenIntegral) did, added to its pair's statistics.
template <class Integration>
void add_integration(PairStats& st, const Integration& h) {
    st.points += h.points;
    st.cells += h.cells;
    st.closed_forms += h.closed_forms;
    st.proven_hidden += h.proven_hidden;
    st.cells_bracketed += h.bracketed;
    if (h.capped) ++st.capped;
}

// The same summed over pairs (per thread, then over threads: sums, maxima and counts, the same
// whatever the order).
using PartialStats = PartlyHiddenStats;
inline constexpr int kLevels = PartlyHiddenStats::kLevels;
inline void add_pair(PartialStats& total, const PairStats& p) {
    total.points += p.points;
    total.cells += p.cells;
    total.closed_forms += p.closed_forms;
    total.proven_hidden += p.proven_hidden;
    total.cells_bracketed += p.cells_bracketed;
    total.capped += static_cast<std::size_t>(p.capped);
    total.bracketed += p.bracketed ? 1 : 0;
    total.settled_by_umbrae += p.settled_by_umbrae ? 1 : 0;
    total.cut_budget_spent += p.budget_spent ? 1 : 0;
    total.integrated_over_seeing_parts += p.seeing_parts ? 1 : 0;
    total.occluded_candidates += p.occluded;
    if (!p.integrated) return;
    total.changed += p.changed ? 1 : 0;
    total.max_error = std::max(total.max_error, p.error);
    ++total.levels[static_cast<std::size_t>(std::min(p.level, kLevels))];
}

// A partly hidden pair's entries: F_sr = f (s the smaller patch), F_rs = back.
struct PartialValue {
    std::size_t s = 0, r = 0;
    double f = 0, back = 0;
    bool integrated = false;  // false: the unobstructed value is 0, nothing to correct
    PairStats stats;
};

// Per-thread sums of PairStats.
using ThreadStats = tbb::enumerable_thread_specific<PartialStats>;
PartialStats combined(ThreadStats& per_thread);

// The sender cut into four: a triangle at its edges' midpoints, a quad at its edges' midpoints
// and its centre (the other polygons whole).
std::vector<Polygon> quarters(const Polygon& p);

// The candidates cand[0, n) of a pair (sender s, receiver r) that no convex solid of another
// candidate hides (BlockerSet::solid_hides()), in their order, into `out`; their number. First
// those a solid hides from all of s: every segment from s to such a piece meets the solid A, so
// a segment from s to r through it meets A first, and the piece's shadow from any point of s
// lies in A's; the union of the shadows, the integrand, is the same without it, and its event
// lines cut nothing that matters (the buildings behind the first ones a wall sees across an
// urban array). The faces of A that those segments enter by meet the pair's shaft, so they are
// candidates; if one is left out too, a solid nearer s hides it, and so on: each step is nearer
// s, and the chain ends at a piece that stays. Then those hidden from all of r by a solid none
// of whose pieces is left out, which then keeps them all: a chain from s's side ends there too.
// Hiders from r that lose pieces would not do: two buildings in a row between two walls each
// hide the other from one of the walls, and both would be left out of the union.
int unoccluded_candidates(const BlockerSet& blockers, const Polygon& s, const Polygon& r,
                          const int* cand, int n, std::vector<int>& out);

// A partly hidden pair whose unobstructed value is at most this share of the tolerance is
// placed inside its bracket [0, unobstructed] without integration (see integrate_partial()).
// Not the whole tolerance: the low-order estimate inside the bracket errs the same way in the
// similar small pairs of a row, and the rows of a closed room of 3,840 triangles (room n = 16,
// each quad two triangles) reached 1.00032 at 1e-4 with the whole tolerance; at 0.3 they are
// within 7e-5 of 1 (the urban array at 1e-4 takes 1.02× the time, its largest error falls from
// 8.4e-5 to 5.7e-5).
inline constexpr double kBracketShare = 0.3;

// A partly hidden pair whose visible part is bounded by at most this share of the tolerance
// (visible_bound()) takes its estimate inside the bound without integration. Not the whole
// tolerance: the estimate (4 points) misses slivers of light near the umbrae's edges, and a
// closed room's rows of such pairs fell 1.4e-4 short of 1 at 1e-4 with the whole tolerance; at
// 0.3, with the points drawn anew in each pair (uniform()'s streams), the rows of the room
// n = 32 are within 8.5e-5 of 1 (at the 2 × 2 Gauss points of every pair, 1.39e-4).
inline constexpr double kUmbraShare = 0.3;

// A pair whose sender's centroid sees more than this many times the umbra share of the
// tolerance is not tried by its umbrae. At 1: none of the pairs they settle is lost (the Cornell
// box 12 × 12, the room n = 16 and the 1,066-triangle urban array, at 1e-4 and 1e-6), and the
// attempts fall by 77% on the Cornell box at 1e-4, 69% on the room, 18% on the urban array (at
// 0.5 the Cornell box lost 1,000 of its 17,240).
inline constexpr double kUmbraTry = 1.0;

// A sender whose own umbra bound is within this factor of its share is tried again as four
// quarters (on the 1,066-triangle urban array at 1e-4: 4,162 more pairs settled, 13% less time;
// trying every sender costs more than it settles).
inline constexpr double kQuartersReach = 16.0;

// A pair whose sender lies this much or more in the umbrae that the occluders cast with the
// receiver as the light is integrated over the rest of the sender only (seen_integral()); with
// less in the umbrae, the parts' own cuts and cells (the umbrae split the sender's seeing part
// into convex pieces) cost about what the whole sender's cut saves. On the 1,066-triangle urban
// array at 1e-4 (1 thread), with every pair of 10 candidates or more trying: 2,308 of its
// 25,344 integrated pairs go this way, 3.80 M points against 5.19 M, 0.89x the time of the
// whole run (at a share of 1, every pair trying: the same points and time as at 0.5); the
// largest error against 1e-8 stays 5.7e-5.
inline constexpr double kSeeingShare = 0.5;

// ... tried on pairs of at least this many candidates: with fewer the cut is small anyway, and
// the umbrae's test costs more than it saves (the rooms with a box: 12% more time when every
// pair tries; 14% fewer points on the urban array's pairs of 10 candidates or more).
inline constexpr int kSeeingCandidates = 10;

// The receiver of a partly hidden pair is integrated over instead of the sender when the event
// lines cut it into fewer pieces and its area is at most this many times the sender's
// (integrate_partial(); room-16-obstruction at 1e-6: 27% fewer cells, 24% fewer points;
// the 1,066-triangle urban array at 1e-4: 15% and 10%, and 11% and 7% with at most 1.5).
inline constexpr double kSideAreaRatio = 4.0;

// ... and when its own cut has at least this many pieces: the other side's cut costs about as
// much as the pieces it saves where there are only two (room-16-obstruction, 1 thread: 0.95×
// the time when every pair with 2 pieces or more tries, 0.89× from 3, 0.91× from 4).
inline constexpr std::size_t kSideMinPieces = 3;

// The sender s (the smaller patch; the lower index of two equal ones) and the receiver r of a
// partly hidden pair.
inline std::pair<std::size_t, std::size_t> sender_receiver(const Scene& scene,
                                                           const PartialPair& pp) {
    std::size_t s = static_cast<std::size_t>(pp.i), r = static_cast<std::size_t>(pp.j);
    const double as = scene.patches[s].area, ar = scene.patches[r].area;
    if (ar < as || (ar == as && r < s)) std::swap(s, r);
    return {s, r};
}

// The unobstructed value less the integrated hidden part, over the smaller patch of the pair
// (reciprocity gives the other entry, with a smaller error). unobstructed(s, r): the exact
// unobstructed F_sr. One code path for the dense matrix, a block of rows, sparse rows and the
// partly hidden pairs apart from the rows.
template <class Unobstructed>
PartialValue integrate_partial(const Scene& scene, const Obstructions& S, const PartialPair& pp,
                               const CandidateLists& lists, double tol,
                               const Unobstructed& unobstructed) {
    PartialValue v;
    const auto [s, r] = sender_receiver(scene, pp);
    v.s = s;
    v.r = r;
    const double a_s = scene.patches[s].area, a_r = scene.patches[r].area;
    const double unobs = unobstructed(s, r);
    if (!(unobs > 0.0)) return v;
    // The pair's candidate pieces, decoded (the lists of a task are stored as varints).
    thread_local std::vector<int> ids;
    if (!lists.decode(pp.cand_first, ids))
        throw Error("analytic: the candidate pieces of a partly hidden pair are out of range");
    const int* pair_cand = ids.data();
    int cand_count = static_cast<int>(ids.size());
    PairStats& st = v.stats;
    // The stream of uniform() that places the pair's value inside its umbra bound.
    const std::uint64_t seed =
        (static_cast<std::uint64_t>(s) << 32) ^ static_cast<std::uint64_t>(r);
    const Polygon& ps = scene.patches[s].polygon;
    const std::vector<Polygon> parts = BlockerSet::convex_parts(scene.patches[r].polygon);
    v.integrated = st.integrated = true;
    // The value f placed inside a bracket [0, top]: its error the larger distance to the ends.
    auto placed = [&](double f, double top) {
        v.f = f;
        st.changed = v.f != unobs;
        st.error = std::max(v.f, top - v.f);
        v.back = a_r > 0.0 ? v.f * a_s / a_r : 0.0;
        return v;
    };
    if (unobs <= kBracketShare * tol) {
        // The bracket 0 ≤ F_sr ≤ unobs holds whatever the blockers do: any value v in it is
        // within max(v, unobs − v) ≤ tol of F_sr. The value is a low-order estimate, so that
        // the small pairs of a row do not all err the same way (the midpoint would).
        double hidden = 0.0;
        for (const Polygon& pr : parts)
            hidden += detail::hidden_estimate(ps, pr, S.blockers, pair_cand, cand_count, S.eps,
                                              st.points);
        const double lo = std::max(0.0, unobs - tol), hi = std::min(unobs, tol);
        st.bracketed = true;
        return placed(std::clamp(unobs - hidden, lo, hi), unobs);
    }
    // Nearly hidden pairs (most partly hidden pairs among buildings): what the sender sees past
    // the umbrae of the occluders bounds the pair's value; within kUmbraShare of the tolerance,
    // the value is placed inside [0, bound] without the event split and its integration.
    // The sender whole first; where its bound is within a few times the share, its four
    // quarters (umbrae from a smaller sender are larger).
    double bound = 0.0, seen = 0.0;
    auto bounded_by = [&](const std::vector<Polygon>& senders) {
        bound = 0.0;
        seen = 0.0;
        for (const Polygon& sp : senders) {
            const double w = area(sp) / a_s;
            for (const Polygon& pr : parts) {
                const detail::VisibleBound b = detail::visible_bound(
                    sp, pr, S.blockers, pair_cand, cand_count, S.eps,
                    (kUmbraShare * tol - bound) / w,
                    seed + 7 * static_cast<std::uint64_t>(&sp - senders.data()));
                st.points += b.points;
                bound += w * b.bound;
                seen += w * b.estimate;
                if (!b.ok || bound > kUmbraShare * tol) return false;
            }
        }
        return true;
    };
    // What the sender's centroid sees of the receiver first (one point): above the share, the
    // umbrae would leave more than that too, and their test (shadows from four corners and a
    // Gauss rule over what they leave, ~5 points' work) is not made.
    double seen_at_centre = 0.0;
    {
        const Vec3 xc = centroid(ps), ns = normal(ps);
        for (const Polygon& pr : parts) {
            double unobstructed_at = 0.0;
            const double hidden_at = detail::point_hidden(xc, ns, pr, S.blockers, pair_cand,
                                                          cand_count, S.eps, &unobstructed_at);
            ++st.points;
            seen_at_centre += unobstructed_at - hidden_at;
        }
    }
    bool bounded = seen_at_centre <= kUmbraTry * kUmbraShare * tol && bounded_by({ps});
    if (!bounded && bound > 0.0 && bound <= kQuartersReach * kUmbraShare * tol)
        bounded = bounded_by(quarters(ps));
    if (bounded) {
        st.settled_by_umbrae = true;
        return placed(std::clamp(seen, 0.0, bound), bound);
    }
    // The candidates that a convex solid among them hides from the whole of either patch
    // (unoccluded_candidates()) are left out of the cut and the integration: the union of the
    // shadows is the same without them.
    thread_local std::vector<int> seen_cand;
    st.occluded = static_cast<std::size_t>(
        cand_count - unoccluded_candidates(S.blockers, ps, scene.patches[r].polygon, pair_cand,
                                           cand_count, seen_cand));
    pair_cand = seen_cand.data();
    cand_count = static_cast<int>(seen_cand.size());
    // Where the occluders' umbrae, with r as the light, leave at most kSeeingShare of s, only
    // the parts of s that may see r are cut and integrated (seen_integral()): the rest sees
    // nothing of r.
    if (parts.size() == 1 && cand_count >= kSeeingCandidates) {
        const detail::SeenIntegral h =
            detail::seen_integral(ps, parts[0], S.blockers, pair_cand, cand_count, tol, S.eps,
                                  kSeeingShare, stream_key(seed, 0, 3));
        if (h.ok) {
            add_integration(st, h);
            st.seeing_parts = true;
            st.error = h.error;
            st.level = h.max_level;
            v.f = std::clamp(h.value, 0.0, unobs);
            st.changed = v.f != unobs;
            v.back = a_r > 0.0 ? v.f * a_s / a_r : 0.0;
            return v;
        }
    }
    // The side to integrate over: the one the event lines cut into fewer pieces, since the
    // cells, and so the work, follow the pieces. Over r only when both patches are convex, r at
    // most kSideAreaRatio times as large as s, and s's cut has kSideMinPieces pieces or more; its
    // hidden part H_rs = H_sr a_s / a_r is then integrated to tol a_s / a_r, so that F_sr stays
    // within tol.
    std::vector<std::vector<Polygon>> cut_s, cut_r;
    std::size_t pieces_s = 0;
    bool spent_s = false, spent_r = false;
    for (const Polygon& pr : parts) {
        bool spent = false;
        cut_s.push_back(detail::event_pieces(ps, pr, S.blockers, pair_cand, cand_count, S.eps,
                                             SIZE_MAX, &spent));
        pieces_s += cut_s.back().size();
        spent_s = spent_s || spent;
    }
    const Polygon& pr_whole = scene.patches[r].polygon;
    bool over_r = false;
    // (s becomes the receiver, which hidden_integral() and the event cut take convex: a patch
    // of a non-convex surface, an L-shaped floor, stays the sender.)
    if (pieces_s >= kSideMinPieces && parts.size() == 1 && a_r <= kSideAreaRatio * a_s &&
        BlockerSet::convex_parts(ps).size() == 1) {
        // (The cut of r stops, empty, once it has as many pieces as s's.)
        cut_r.push_back(detail::event_pieces(pr_whole, ps, S.blockers, pair_cand, cand_count, S.eps,
                                             pieces_s, &spent_r));
        over_r = !cut_r.back().empty();
    }
    st.budget_spent = over_r ? spent_r : spent_s;
    const Polygon& sender = over_r ? pr_whole : ps;
    const std::vector<Polygon>& receivers = over_r ? std::vector<Polygon>{ps} : parts;
    const std::vector<std::vector<Polygon>>& cuts = over_r ? cut_r : cut_s;
    // H_sr from what is integrated: ×1 over s, × a_r / a_s over r.
    const double to_sr = over_r ? a_r / a_s : 1.0;
    double hidden_sum = 0.0, err = 0.0;
    int level = 0;
    for (std::size_t k = 0; k < receivers.size(); ++k) {
        const detail::HiddenIntegral h =
            detail::hidden_integral(sender, receivers[k], S.blockers, pair_cand, cand_count,
                                    tol / to_sr / static_cast<double>(receivers.size()), S.eps,
                                    &cuts[k], stream_key(seed, k, 0));
        hidden_sum += h.hidden * to_sr;
        err += h.error * to_sr;
        level = std::max(level, h.max_level);
        add_integration(st, h);
    }
    v.f = std::clamp(unobs - hidden_sum, 0.0, unobs);
    st.changed = v.f != unobs;
    v.back = a_r > 0.0 ? v.f * a_s / a_r : 0.0;
    st.error = err;
    st.level = level;
    return v;
}

// details["obstructions"] (docs/analytic.md): the blockers, the pair classes, the integration.
void report_obstructions(const Obstructions& S, const PartialStats& total, std::size_t node_pairs,
                         std::size_t visible, std::size_t hidden, std::size_t partial, double tol,
                         int threads, Fields& o);

}  // namespace formfactor::detail
