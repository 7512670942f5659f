// The adaptive integration of the hidden part of a partly hidden pair over the sender
// (Walton's adaptive method, NISTIR 6925): the sender cut along its event lines
// (discontinuity_mesh.cpp), each piece mapped from the unit square and integrated cell by cell by
// tensor Gauss rules of the exact point kernel (point_kernel.cpp), the cells with the largest
// error estimates split until their sum is within the target. The public functions of
// formfactor/methods/obstructed.h that use it: obstructed_polygons.cpp. See docs/analytic.md,
// "Obstructed scenes".

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <queue>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/random.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"
#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/point_kernel.h"
#include "methods/analytic/sender_cells.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

namespace {

// Cells where the shaft test finds a blocker but no sample point sees a shadow get their whole
// unobstructed contribution as the error estimate (forcing subdivision) down to this level; below
// it such a shadow is a sliver along a shadow boundary, whose part the normal estimate covers.
constexpr int kSuspiciousLevels = 4;

// A cell whose bracket (point_factor_bound()) is at most this share of the pair's target takes a
// value inside it from one point, integrated only if the pair's error needs it. Measured on the
// 1,066-triangle urban array at 1e-4 (1 thread): 0.05 → 5.89 M points, 0.2 → 5.59 M, 1 → 5.49 M
// (7.47 M without), the time least at 0.2 (14.0 → 12.2 s); at 1 more cells are bracketed only to
// be integrated after all.
constexpr double kCellBracket = 0.2;

}  // namespace

double point_hidden(const Vec3& x, const Vec3& n, const Polygon& r, const BlockerSet& blockers,
                    const int* cand, int count, double eps, double* unobstructed) {
    const Receiver rc(r);
    const PointResult res =
        evaluate_point(rc, x, n, blockers, cand, count, eps, unobstructed != nullptr);
    if (unobstructed) *unobstructed = res.unobstructed;
    return std::min(res.hidden, unobstructed ? res.unobstructed : res.hidden);
}

double hidden_estimate(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                       const int* cand, int n, double eps, std::size_t& points) {
    const double area_s = area(s);
    if (!(area_s > 0.0) || n == 0) return 0.0;
    const Vec3 ns = normal(s);
    const Receiver rc(r);
    // The degree-2 rule of a triangle (points 2/3, 1/6, 1/6 in barycentric coordinates, equal
    // weights) on each triangle of s's fan.
    double sum = 0.0;
    for (std::size_t k = 1; k + 1 < s.size(); ++k) {
        const Vec3 &a = s[0], &b = s[k], &c = s[k + 1];
        const double w = 0.5 * (b - a).cross(c - a).norm() / (3.0 * area_s);
        for (int q = 0; q < 3; ++q) {
            const Vec3 corner = q == 0 ? a : q == 1 ? b : c;
            const Vec3 x = (a + b + c + 3.0 * corner) / 6.0;
            sum += w * evaluate_point(rc, x, ns, blockers, cand, n, eps, false).hidden;
            ++points;
        }
    }
    return sum;
}

std::vector<Polygon> event_pieces(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                                  const int* cand, int n, double eps, std::size_t max_pieces,
                                  bool* budget_spent) {
    return split_by_events(s, normal(s), Receiver(r), blockers, cand, n, eps, max_pieces,
                           budget_spent);
}

HiddenIntegral hidden_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                               const int* cand, int n, double target, double eps,
                               const std::vector<Polygon>* cut, std::uint64_t seed) {
    HiddenIntegral out;
    const double area_s = area(s);
    if (!(area_s > 0.0) || n == 0) return out;
    const Vec3 ns = normal(s);
    const Receiver rc(r);
    // The lowest elevation above the sender's plane at which a point of s sees a point of r:
    // sin θ_r ≥ (the receiver's lowest height above that plane) / (the largest sender–receiver
    // vertex distance); 0 when r reaches down to the plane. Directions below θ_r meet no part
    // of r, so nothing seen only below θ_r hides any of it.
    double sin_receiver = 0.0;
    {
        double hmin = INFINITY, dmax = 0.0;
        for (const Vec3& q : r.vertices) {
            hmin = std::min(hmin, ns.dot(q - s[0]));
            for (const Vec3& v : s.vertices) dmax = std::max(dmax, (q - v).norm());
        }
        if (hmin > 0.0 && dmax > 0.0) sin_receiver = std::min(1.0, hmin / dmax);
    }
    const double sin2_receiver = sin_receiver * sin_receiver;
    // Sender pieces: the sender cut along the lines where the integrand has kinks, then
    // triangles (or the sender's own quad when nothing cuts it).
    std::vector<Polygon> own_cut;
    if (cut == nullptr) own_cut = split_by_events(s, ns, rc, blockers, cand, n, eps);
    const std::vector<Polygon>& pieces = cut != nullptr ? *cut : own_cut;
    // Each convex piece is mapped from the unit square by quads (0, k, k+1, k+2) of its fan
    // (convex, as parts of a convex polygon) and a last triangle when the count is odd: half
    // the maps, so half the cells, of a fan of triangles. Slivers below 1e-12 of the sender
    // (rounding pieces of the cut) are not integrated: F(x → r) ≤ 1 bounds what they hold,
    // and that bound goes into the error.
    // Per-pair buffers, reused across the pairs a thread integrates.
    thread_local std::vector<SenderMap> maps;
    maps.clear();
    double sliver_error = 0.0;
    auto add_map = [&](const SenderMap& m, double a) {
        if (a <= 1e-12 * area_s) {
            sliver_error += a / area_s;
            return;
        }
        maps.push_back(m);
    };
    for (const Polygon& pc : pieces) {
        const std::size_t nv = pc.size();
        std::size_t k = 1;
        for (; k + 2 < nv; k += 2) {
            SenderMap m;
            m.quad = true;
            m.p0 = pc[0];
            m.p1 = pc[k];
            m.p2 = pc[k + 1];
            m.p3 = pc[k + 2];
            const double a = 0.5 * ((m.p2 - m.p0).cross(m.p3 - m.p1)).norm();
            add_map(m, a);
        }
        if (k + 1 < nv) {
            SenderMap m;
            m.p0 = pc[0];
            m.p1 = pc[k];
            m.p2 = pc[k + 1];
            m.tri_j = (m.p1 - m.p0).cross(m.p2 - m.p1).norm();
            add_map(m, 0.5 * m.tri_j);
        }
    }
    const CellRules rules;
    thread_local std::vector<int> kept;
    thread_local std::vector<int> cell_cand;
    thread_local std::vector<int> facing;        // the candidates that some point of a cell faces
    thread_local std::vector<int> put_off_cand;  // the candidates of cells whose order 4 waits
    put_off_cand.clear();
    const double inv_area = 1.0 / area_s;

    // bracket_ok: the cell may be settled by its bracket (not when the heap returns it for
    // integration).
    auto process = [&](Cell& c, bool bracket_ok) {
        const SenderMap& m = maps[static_cast<std::size_t>(c.map)];
        Vec3 corner[4] = {m.at(c.u0, c.v0), m.at(c.u1, c.v0), m.at(c.u1, c.v1), m.at(c.u0, c.v1)};
        Vec3 poly[4];
        int np = 0;
        for (const Vec3& q : corner)
            if (np == 0 || (q - poly[np - 1]).squaredNorm() > 0.0) poly[np++] = q;
        while (np > 1 && (poly[0] - poly[np - 1]).squaredNorm() == 0.0) --np;
        c.value = 0.0;
        c.error = 0.0;
        if (np < 3) return;
        const double du = c.u1 - c.u0, dv = c.v1 - c.v0;
        const double scale = du * dv * inv_area;
        // The cell's share of the target: its part of the sender's area (the 2 × 2 rule
        // integrates the bilinear and the collapsed map's Jacobians exactly), so that the cells
        // that end by agreement of orders 2 and 3 never add up to more than the target.
        const auto one = [](double, double) { return 1.0; };
        const double frac =
            tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g2, kLowOrder, one) * scale;
        // The cell's bracket: its hidden part lies between 0 and its unobstructed part, at most
        // frac × (a bound on F(x → r) over the cell). Where that is a small share of the target,
        // a value inside it from the cell's midpoint, its error the larger distance to the
        // bracket's ends, is enough until the pair's total error says otherwise: then the heap
        // returns the cell and it is integrated (slivers of the event split, cells far from the
        // receiver: on the urban array at 1e-4, 133k of 440k cells end so). The bracket comes
        // before the cell's shaft: its one point looks through the pair's candidates, which
        // costs less than building the shaft and testing each candidate against it (on the
        // urban array at 1e-4, 4% of the time).
        c.bracketed = false;
        if (bracket_ok) {
            const double b =
                frac * point_factor_bound(poly, np, ns, rc, kCellBracket * target / frac);
            if (b <= kCellBracket * target) {
                const double um = 0.5 * (c.u0 + c.u1), vm = 0.5 * (c.v0 + c.v1);
                const PointResult pr =
                    evaluate_point(rc, m.at(um, vm), ns, blockers, cand, n, eps, false);
                ++out.points;
                c.value = std::clamp(pr.hidden * m.jacobian(um, vm) * scale, 0.0, b);
                c.error = std::max(c.value, b - c.value);
                c.bracketed = true;
                return;
            }
        }
        // The back faces of culled solids that face away from every point of the cell are left
        // out before its shaft: a segment from a point of the cell that meets such a solid
        // enters it through a face in front of that point, which meets the shaft too, so the
        // cell's class is the same without them, and no point of the cell sees them (the far
        // side of a faceted sphere: half of its faces are not tested against the shaft).
        thread_local std::vector<std::pair<int, bool>> culls;  // (solid, culls_polygon())
        culls.clear();
        auto back_everywhere = [&](int k) {
            const auto& pc = blockers.piece(k);
            if (!pc.cull_back && pc.solid < 0) return false;
            for (int q = 0; q < np; ++q)
                if (pc.plane.signed_distance(poly[q]) > 0.0) return false;
            if (pc.cull_back) return true;
            for (const auto& [so, yes] : culls)
                if (so == pc.solid) return yes;
            const bool yes = blockers.culls_polygon(k, poly, np);
            culls.emplace_back(pc.solid, yes);
            return yes;
        };
        facing.clear();
        for (int j = 0; j < n; ++j)
            if (!back_everywhere(cand[j])) facing.push_back(cand[j]);
        Shaft sh;
        sh.build(poly, np, ns, rc.poly.v.data(), rc.poly.n, rc.n, eps);
        if (sh.facing_away()) return;
        const ShaftClass cls = classify_shaft(sh, blockers, facing.data(),
                                              static_cast<int>(facing.size()), kept, false);
        if (cls == ShaftClass::kVisible) return;
        // F(x → r) at the point (u, v) of the cell, past nothing.
        auto unobstructed = [&](double u, double v) {
            return evaluate_point(rc, m.at(u, v), ns, blockers, nullptr, 0, eps, true).unobstructed;
        };
        // Hidden: the cell's whole unobstructed part. F(x → r) is smooth on the cell: orders 2
        // and 3 of it agreeing kAgreement times better than the cell's share of the target (as
        // for a partly hidden cell below) give its integral for 13 evaluations of Lambert's
        // formula; else the closed form, whose edge integrals resolved to 1e-16 cost many times
        // more.
        // A cell that sees nothing of the receiver: its whole unobstructed part.
        auto whole_cell = [&]() {
            ++out.closed_forms;
            auto counted = [&](double u, double v) {
                ++out.points;
                return unobstructed(u, v);
            };
            const double q2 = tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g2, kLowOrder, counted);
            const double q3 = tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g3, kMidOrder, counted);
            const double e23 = std::abs(q3 - q2) * scale;
            if (kAgreement * e23 <= target * frac) {
                c.value = q3 * scale;
                c.error = kAgreement * e23;
                return;
            }
            Polygon cp;
            cp.vertices.assign(poly, poly + np);
            c.value = polygon_to_polygon(cp, r) * area(cp) * inv_area;
            c.error = 1e-12 * area(cp) * inv_area;
        };
        if (cls == ShaftClass::kHidden) {
            whole_cell();
            return;
        }
        // Pieces that face the cell first: the shadows of the others (the back faces of a closed
        // solid) then mostly vanish in the union.
        cell_cand.clear();
        const Vec3 mid = m.at(0.5 * (c.u0 + c.u1), 0.5 * (c.v0 + c.v1));
        for (int pass = 0; pass < 2; ++pass)
            for (int k : kept)
                if ((blockers.piece(k).plane.signed_distance(mid) > 0.0) == (pass == 0))
                    cell_cand.push_back(k);
        double q2 = 0.0, q3 = 0.0;
        bool any_hidden = false, any_visible = false;
        auto f = [&](double u, double v) {
            ++out.points;
            return evaluate_point(rc, m.at(u, v), ns, blockers, cell_cand.data(),
                                  static_cast<int>(cell_cand.size()), eps, false);
        };
        // Tensor Gauss rules of orders 2, 3 and 4 (29 points): the order-4 value, the larger of
        // the two differences its error estimate. Two low orders alone can agree by chance while
        // both are off (seen: orders 2 and 3 within 4e-8 of each other and 1.75e-6 from the
        // integral, which order 4 gets to 1.2e-7); three rules must all agree.
        double q4 = 0.0;
        // first: the rule's first point, centre: its middle one (order 3's), when the caller has
        // them already.
        auto rule = [&](const GaussRule& g, int order, const PointResult* first = nullptr,
                        const PointResult* centre = nullptr) {
            // The k-th point of the rule: (0, 0) at k = 0, (1, 1) at k = order + 1.
            int k = 0;
            return tensor_rule(m, c.u0, c.u1, c.v0, c.v1, g, order, [&](double u, double v) {
                const int at = k++;
                const PointResult pr = at == 0 && first            ? *first
                                       : at == order + 1 && centre ? *centre
                                                                   : f(u, v);
                any_hidden = any_hidden || pr.hidden > 0.0;
                any_visible = any_visible || !pr.all_hidden;
                return pr.hidden;
            });
        };
        // Order 2's first point first: where it sees nothing of the receiver, the umbrae of the
        // candidates may cover the receiver from the whole cell (no gap of light between their
        // shadows anywhere in it): a hidden cell after all, found without order 2's other three
        // points (on the urban array at 1e-4, 66k of 428k cells; 0.97× the time of trying only
        // where all four of them see nothing). Where they leave little of it, what the cell
        // sees lies in [0, the bound from what they leave]: at most kCellBracket of the pair's
        // target, the cell is settled inside it as the pairs of visible_bound() are, its
        // visible part from one point drawn in each quarter of the cell (a random point of
        // the pair's stream: fixed ones would err alike in the similar pairs of a row), until
        // the pair's total error says otherwise (then the heap returns it, as a bracketed cell).
        const PointResult first = f(c.u0 + du * rules.g2.x[0], c.v0 + dv * rules.g2.x[0]);
        if (first.all_hidden && first.hidden > 0.0) {
            const CellUmbra cu = cell_umbra(rc, m, c.u0, c.u1, c.v0, c.v1, poly, np, ns, blockers,
                                            cell_cand.data(), static_cast<int>(cell_cand.size()),
                                            eps, scale, bracket_ok ? kCellBracket * target : NAN);
            if (cu.hidden) {
                ++out.proven_hidden;
                whole_cell();
                return;
            }
            if (bracket_ok && cu.ok && cu.bound <= kCellBracket * target) {
                whole_cell();
                // The cell's stream: the pair's, keyed by the cell's place in its piece's map.
                const std::uint64_t key = stream_key(seed, static_cast<std::uint64_t>(c.map),
                                                     std::bit_cast<std::uint64_t>(c.u0),
                                                     std::bit_cast<std::uint64_t>(c.v0));
                const double seen = seen_at_drawn_points(
                    rc, m, c.u0, c.u1, c.v0, c.v1, ns, blockers, cell_cand.data(),
                    static_cast<int>(cell_cand.size()), eps, key, out.points);
                const double visible = std::clamp(seen * scale, 0.0, cu.bound);
                c.value -= visible;
                c.error += std::max(visible, cu.bound - visible);
                c.bracketed = true;
                return;
            }
        }
        q2 = rule(rules.g2, kLowOrder, &first);
        const bool shadow_at_order2 = any_hidden;
        if (any_hidden && !any_visible) {
            // Orders 2 and 4 first where order 2's points see nothing of the receiver (in the
            // shadow of several buildings together: most cells of a partly hidden pair in an
            // urban array). Where order 4's see nothing either, the integrand at all 20 points
            // is F(x → r), smooth, and order 3 is not needed; the 16 points of order 4 are the
            // ones that find a gap of light between two shadows (13 points of orders 2 and 3
            // were seen to miss such gaps).
            q4 = rule(rules.g4, kHighOrder);
            if (!any_visible) {
                c.value = q4 * scale;
                c.error = std::abs(q4 - q2) * scale;
                return;
            }
            q3 = rule(rules.g3, kMidOrder);
            c.value = q4 * scale;
            c.error = std::max(std::abs(q4 - q3), std::abs(q3 - q2)) * scale;
            return;
        }
        // Where order 2's points see both shadow and light, the cell's centre (a point of order
        // 3) next: order 2 and the one-point rule agreeing kAgreement times better than the
        // cell's share of the target give order 2 with kAgreement × their difference as its
        // error, for 5 points rather than 13 (the one-point rule errs far more than order 2 on
        // a smooth piece, so their difference is the larger; on the 1,066-triangle urban array
        // at 1e-4, 25k of the 110k cells that orders 2 and 3 would settle end here, and the
        // largest error against a 1e-8 run stays 5.7e-5). Else the centre is order 3's.
        PointResult centre;
        const bool with_centre = any_hidden && any_visible;
        if (with_centre) {
            const double uc = c.u0 + du * rules.g3.x[1], vc = c.v0 + dv * rules.g3.x[1];
            centre = f(uc, vc);
            const double e12 = std::abs(q2 - m.jacobian(uc, vc) * centre.hidden) * scale;
            if (kAgreement * e12 <= target * frac) {
                c.value = q2 * scale;
                c.error = kAgreement * e12;
                return;
            }
        }
        q3 = rule(rules.g3, kMidOrder, nullptr, with_centre ? &centre : nullptr);
        // Orders 2 and 3 agreeing kAgreement times better than the cell's share of the target:
        // order 3 is taken with kAgreement × their difference as its error, without order 4's
        // 16 points. Where the target is loose (--tolerance 1e-4) most smooth pieces end here.
        const double e23 = std::abs(q3 - q2) * scale;
        // Only where the points see both shadow and light: samples that all fall in the umbra
        // (or all in the light) of a partly hidden cell agree whatever lies between them.
        if (any_hidden && any_visible && kAgreement * e23 <= target * frac) {
            c.value = q3 * scale;
            c.error = kAgreement * e23;
        } else if (bracket_ok && any_visible && shadow_at_order2 && kAgreement * e23 <= target) {
            // Orders 2 and 3 agree, though not within the cell's share of the target: order
            // 3's value with kAgreement × their difference as its estimate, as above, while the
            // pair's total allows it; order 4 (16 points) only when the heap returns the cell.
            // Not on a cell the heap returned for integration (bracket_ok false): that one is
            // integrated in full now.
            c.value = q3 * scale;
            c.error = kAgreement * e23;
            c.q2 = q2;
            c.q3 = q3;
            c.cand_at = static_cast<int>(put_off_cand.size());
            c.cand_n = static_cast<int>(cell_cand.size());
            put_off_cand.insert(put_off_cand.end(), cell_cand.begin(), cell_cand.end());
            return;
        } else if (e23 > target) {
            // The cell alone exceeds the pair's target: it will be split whatever order 4
            // says, and its estimate is at least this difference.
            c.value = q3 * scale;
            c.error = std::abs(q3 - q2) * scale;
        } else {
            q4 = rule(rules.g4, kHighOrder);
            c.value = q4 * scale;
            c.error = std::max(std::abs(q4 - q3), std::abs(q3 - q2)) * scale;
        }
        // Partly hidden by its shaft, yet no sample point sees a shadow: the shadow may fall
        // between the points; what it can hide is at most the cell's unobstructed part. So too
        // where order 2's points see none and only those of orders 3 and 4 do: a shadow narrower
        // than the 2 × 2 points' spacing, on which orders 3 and 4 can agree while missing most
        // of it (seen: a faceted sphere's shadow edge across a cell, the estimate from orders 2
        // to 4 20× below the cell's error).
        if ((!any_hidden || !shadow_at_order2) && c.level < kSuspiciousLevels) {
            // Unless the exact test finds that no piece meets the cell's shaft after all.
            // What a piece meeting the shaft can hide from a point x: the directions from x
            // to it rise at most h/δ above the sender's plane (h the piece's largest height
            // above it, δ ≤ |y − x| the distance from the cell to its part in front), the
            // directions to r at least θ_r, and the cosine-weighted share of the directions
            // between elevations θ_r and θ is sin²θ − sin²θ_r. For a piece hovering just above
            // the sender (jittered contact) this is far below the cell's whole unobstructed
            // part, and 0 once the piece is seen lower than any part of r.
            bool meets = false;
            double share = 0.0;  // bound on the hidden share of the hemisphere, summed
            for (int k : cell_cand) {
                const auto& pc = blockers.piece(k);
                const Vec3* pv = blockers.vertices(k);
                if (sh.piece_outside(pv, pc.count, pc.plane, true)) continue;
                // The piece's part in front of the sender's plane, its height and its distance
                // from the cell.
                Poly3 whole, front;
                whole.n = pc.count;
                std::copy(pv, pv + pc.count, whole.v.begin());
                clip3(whole, ns, ns.dot(poly[0]), front);
                if (front.n == 0) continue;  // nothing in front: cannot block
                meets = true;
                double h = 0.0;
                for (int q = 0; q < front.n; ++q)
                    h = std::max(h, ns.dot(front.v[static_cast<std::size_t>(q)] - poly[0]));
                const double gap = polygon_distance(poly, np, front.v.data(), front.n);
                const double gap2 = gap * gap;
                // The directions to it rise at most h/δ above the plane: the share between θ_r
                // and that elevation.
                share += std::max(0.0, (gap2 > h * h ? h * h / gap2 : 1.0) - sin2_receiver);
                if (share >= 1.0) break;
            }
            if (meets && share > 0.0) {
                // What the cell sees of the receiver: a bound on what a shadow can hide.
                const double u3 =
                    tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g3, kMidOrder, unobstructed);
                const double cell_area =
                    share < 1.0 ? tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g3, kMidOrder, one)
                                : 0.0;
                c.error = std::max(
                    c.error, share < 1.0 ? std::min(u3, share * cell_area) * scale : u3 * scale);
            }
        }
    };

    // A cell whose order 4 was put off: order 4 on it now, with the candidates of its shaft.
    auto order4 = [&](Cell& c) {
        const SenderMap& m = maps[static_cast<std::size_t>(c.map)];
        const double scale = (c.u1 - c.u0) * (c.v1 - c.v0) * inv_area;
        const double q4 =
            tensor_rule(m, c.u0, c.u1, c.v0, c.v1, rules.g4, kHighOrder, [&](double u, double v) {
                ++out.points;
                return evaluate_point(rc, m.at(u, v), ns, blockers, put_off_cand.data() + c.cand_at,
                                      c.cand_n, eps, false)
                    .hidden;
            });
        c.value = q4 * scale;
        c.error = std::max(std::abs(q4 - c.q3), std::abs(c.q3 - c.q2)) * scale;
        c.cand_at = -1;
    };
    auto worse = [](const Cell& a, const Cell& b) { return a.error < b.error; };
    thread_local std::vector<Cell> heap;
    heap.clear();
    double total_error = 0.0;
    for (std::size_t k = 0; k < maps.size(); ++k) {
        Cell c;
        c.map = static_cast<int>(k);
        process(c, true);
        total_error += c.error;
        heap.push_back(c);
    }
    std::make_heap(heap.begin(), heap.end(), worse);
    constexpr std::size_t kMaxCells = 4096;
    constexpr int kMaxLevel = 14;
    thread_local std::vector<Cell> done;
    done.clear();
    while (total_error > target && !heap.empty()) {
        std::pop_heap(heap.begin(), heap.end(), worse);
        Cell c = heap.back();
        heap.pop_back();
        if (c.level >= kMaxLevel || heap.size() + done.size() + 4 > kMaxCells) {
            out.capped = true;
            done.push_back(c);
            if (heap.size() + done.size() + 4 > kMaxCells) break;
            continue;
        }
        if (c.cand_at < 0 && !c.bracketed) {
            // Before any cell is split, the cells whose order 4 waits take it, the largest
            // estimate first: 16 points each, where a split costs four cells.
            std::size_t at = heap.size();
            for (std::size_t k = 0; k < heap.size(); ++k)
                if (heap[k].cand_at >= 0 && (at == heap.size() || heap[at].error < heap[k].error))
                    at = k;
            if (at < heap.size()) {
                std::swap(c, heap[at]);
                std::make_heap(heap.begin(), heap.end(), worse);
            }
        }
        total_error -= c.error;
        if (c.cand_at >= 0) {
            order4(c);
            total_error += c.error;
            heap.push_back(c);
            std::push_heap(heap.begin(), heap.end(), worse);
            continue;
        }
        if (c.bracketed) {
            // Its bracket is the largest error left: integrate it, on the same cell.
            process(c, false);
            total_error += c.error;
            heap.push_back(c);
            std::push_heap(heap.begin(), heap.end(), worse);
            continue;
        }
        const double um = 0.5 * (c.u0 + c.u1), vm = 0.5 * (c.v0 + c.v1);
        const double us[3] = {c.u0, um, c.u1}, vs[3] = {c.v0, vm, c.v1};
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) {
                Cell ch;
                ch.map = c.map;
                ch.u0 = us[i];
                ch.u1 = us[i + 1];
                ch.v0 = vs[j];
                ch.v1 = vs[j + 1];
                ch.level = c.level + 1;
                process(ch, true);
                total_error += ch.error;
                heap.push_back(ch);
                std::push_heap(heap.begin(), heap.end(), worse);
            }
    }
    for (const Cell& c : heap) done.push_back(c);
    // Sum in a fixed order so that the result does not depend on the heap's history.
    std::sort(done.begin(), done.end(), [](const Cell& a, const Cell& b) {
        return std::tie(a.map, a.u0, a.v0) < std::tie(b.map, b.u0, b.v0);
    });
    double err = 0.0;
    for (const Cell& c : done) {
        out.hidden += c.value;
        err += c.error;
        out.max_level = std::max(out.max_level, c.level);
        if (c.bracketed) ++out.bracketed;
    }
    out.error = err + sliver_error;
    out.cells = done.size();
    return out;
}

}  // namespace formfactor::detail
