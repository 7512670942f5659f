// F(s → r) of a partly hidden pair integrated only where the sender can see some of the
// receiver: the receiver as the light and the occluders' umbrae on the sender's plane
// (seeing_part(), umbrae.cpp: the conservative visibility bounds of Lischinski, Smits &
// Greenberg 1994 with the roles of the patches swapped). From the rest of the sender nothing of
// the receiver is seen, so F has nothing there to integrate. Between buildings most of a sender
// that faces a wall past many others lies in the umbra of some building or other; the event cut
// of the whole sender (along every event line of every candidate: hundreds of pieces, each
// integrated) then costs far more than the cut of the few parts that see light. See
// docs/analytic.md, "Where the sender sees the receiver".

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "formfactor/core/random.h"
#include "formfactor/kernels/analytic.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor::detail {

namespace {

// The share of the pair's target that its seeing parts are integrated to. Not the whole target:
// the parts are the slivers of light along the umbrae's edges, where the cells' estimates (their
// brackets from one point) err alike in the similar pairs of a row, and the rows of the closed
// room n = 32 at 1e-4 reached 1 + 1.08e-4 with the whole target; at 0.5 (and 0.7, 0.2) they are
// within 8.5e-5 of 1, as without the seeing parts. The urban array 7 x 7 at 1e-4 takes 4% more
// points at 0.5 than at 1.
constexpr double kPartShare = 0.5;

}  // namespace

SeenIntegral seen_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                           const int* cand, int n, double target, double eps, double share,
                           std::uint64_t seed) {
    SeenIntegral out;
    const double area_s = area(s);
    if (!(area_s > 0.0) || n == 0) return out;
    thread_local std::vector<Polygon> seeing;
    if (!seeing_part(s, r, blockers, cand, n, eps, seeing)) return out;
    double a_seeing = 0.0;
    for (const Polygon& p : seeing) a_seeing += area(p);
    if (a_seeing > share * area_s) return out;  // little in the umbrae: the whole sender is cut
    out.ok = true;
    out.parts = seeing.size();
    // Each part p (a convex polygon) contributes w = A_p / A_s times F(p → r): its unobstructed
    // closed form less its hidden part, integrated to kPartShare × target × A_s / (the parts'
    // area), so that the parts' errors, weighted by w, add up to at most that share of the
    // target.
    const double part_target = kPartShare * (a_seeing > 0.0 ? target * area_s / a_seeing : target);
    thread_local std::vector<int> kept;
    const Vec3 nr = normal(r);
    for (std::size_t k = 0; k < seeing.size(); ++k) {
        const Polygon& p = seeing[k];
        const double w = area(p) / area_s;
        if (!(w > 0.0)) continue;
        // The part's own shaft keeps the candidates that matter to it: fewer event lines.
        Shaft sh;
        sh.build(p.vertices.data(), static_cast<int>(p.size()), normal(p), r.vertices.data(),
                 static_cast<int>(r.size()), nr, eps);
        if (sh.facing_away()) continue;
        const ShaftClass cls = classify_shaft(sh, blockers, cand, n, kept, false);
        if (cls == ShaftClass::kHidden) continue;
        const double unobstructed = polygon_to_polygon(p, r);
        if (cls == ShaftClass::kVisible) {
            out.value += w * unobstructed;
            out.error += w * 1e-12 * unobstructed;
            continue;
        }
        const HiddenIntegral h =
            hidden_integral(p, r, blockers, kept.data(), static_cast<int>(kept.size()), part_target,
                            eps, nullptr, stream_key(seed, k, 2));
        out.value += w * (unobstructed - h.hidden);
        out.error += w * h.error;
        out.points += h.points;
        out.cells += h.cells;
        out.closed_forms += h.closed_forms;
        out.proven_hidden += h.proven_hidden;
        out.bracketed += h.bracketed;
        out.capped = out.capped || h.capped;
        out.max_level = std::max(out.max_level, h.max_level);
    }
    return out;
}

}  // namespace formfactor::detail
