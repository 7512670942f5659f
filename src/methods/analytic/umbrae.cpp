// Umbrae of a sender: the part of the receiver that an occluder (a convex solid, or a piece
// alone) hides from every point of a convex sender cell is the intersection of its shadows from
// the cell's corners. A cell whose umbrae cover the receiver sees none of it, and what they
// leave bounds what a cell (cell_umbra()) or a sender (visible_bound()) sees: the conservative
// visibility
// bounds of Lischinski, Smits & Greenberg (1994), here from exact shadow polygons. With the roles
// swapped, the umbrae that the occluders cast on the sender's plane with the receiver as the
// light leave the part of the sender that may see the receiver (seeing_part()). See
// docs/analytic.md, "Pairs settled by their umbrae".

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "formfactor/core/random.h"
#include "methods/analytic/point_kernel.h"
#include "methods/analytic/sender_cells.h"

namespace formfactor::detail {

namespace {

// True when no point of the convex cell poly[0, np) (in the sender's plane, normal nx) sees any
// of the receiver: every point of the receiver's part in front lies in the umbra of one
// occluder, a convex solid or a piece alone. An occluder's umbra, the points y hidden by it from
// every point of the cell, is the intersection of its shadows from the cell's corners: the
// points x whose segment to a fixed y meets a convex set form a convex set (see the solid test
// of classify_shaft()), so y hidden from every corner is hidden from the whole cell. The umbrae
// of different occluders cover the receiver together where the shadows of one sample point do
// not prove it for the next: a gap of light between two shadows opens across the cell (an
// edge-edge-edge event) only where the umbrae leave one. Occluders whose shadow is not one
// polygon at every corner (a solid that a corner does not cull, a silhouette fanned into
// several polygons) are left out, which only makes the test fail more often.
//
// umbra_remainder() gives what is left of the receiver (its part in front, in its plane's
// coordinates, `frags`) after the umbrae, for a bound on what the cell sees; false when no
// occluder has an umbra (nothing to bound with).
bool umbra_remainder(const Receiver& rc, const Vec3* poly, int np, const Vec3& nx,
                     const BlockerSet& blockers, const int* cand, int count, double eps,
                     std::vector<Poly2>& frags) {
    frags.clear();
    if (count == 0 || np < 3 || np > 4) return false;
    thread_local std::array<std::vector<Poly2>, 4> shadows;
    thread_local std::array<std::vector<int>, 4> ids;
    Poly2 whole;
    for (int c = 0; c < np; ++c) {
        double h = 0.0;
        Poly3 rp;
        Poly2 w;
        if (!receiver_in_front(rc, poly[c], nx, h, rp, w)) return false;
        if (c == 0) whole = w;
        cast_shadows(rc, poly[c], h, rp, w, blockers, cand, count, eps,
                     shadows[static_cast<std::size_t>(c)], ids[static_cast<std::size_t>(c)]);
        if (shadows[static_cast<std::size_t>(c)].empty()) return false;
    }
    // The index of the one shadow of occluder `id` at corner c, or −1 (none, or several).
    auto only = [&](int c, int id) {
        const std::vector<int>& v = ids[static_cast<std::size_t>(c)];
        int at = -1;
        for (std::size_t k = 0; k < v.size(); ++k)
            if (v[k] == id) {
                if (at >= 0) return -1;
                at = static_cast<int>(k);
            }
        return at;
    };
    thread_local std::vector<Poly2> umbrae, next;
    umbrae.clear();
    Poly2 buf[2];
    for (std::size_t k = 0; k < shadows[0].size(); ++k) {
        const int id = ids[0][k];
        if (only(0, id) != static_cast<int>(k)) continue;
        Poly2* cur = &buf[0];
        Poly2* tmp = &buf[1];
        copy2(shadows[0][k], *cur);
        for (int c = 1; c < np && cur->n >= 3; ++c) {
            const int at = only(c, id);
            if (at < 0) {
                cur->n = 0;
                break;
            }
            const Poly2& q = shadows[static_cast<std::size_t>(c)][static_cast<std::size_t>(at)];
            const double sign = area2(q) > 0.0 ? 1.0 : -1.0;
            bool any_edge = false;
            for (int e = 0; e < q.n && cur->n >= 3; ++e) {
                const auto a = static_cast<std::size_t>(e);
                const auto b = static_cast<std::size_t>(e + 1 == q.n ? 0 : e + 1);
                const double ex = q.x[b] - q.x[a], ey = q.y[b] - q.y[a];
                if (ex == 0.0 && ey == 0.0) continue;
                any_edge = true;
                clip2(*cur, q.x[a], q.y[a], ex, ey, sign, *tmp);
                std::swap(cur, tmp);
            }
            // A shadow shrunk to one point (its vertices all equal) leaves no umbra, not the
            // shadows so far.
            if (!any_edge) cur->n = 0;
        }
        const double cur_area = cur->n >= 3 ? area2(*cur) : 0.0;
        if (cur_area == 0.0) continue;
        if (cur_area < 0.0) {
            std::reverse(cur->x.begin(), cur->x.begin() + cur->n);
            std::reverse(cur->y.begin(), cur->y.begin() + cur->n);
        }
        umbrae.emplace_back();
        copy2(*cur, umbrae.back());
    }
    if (umbrae.empty()) return false;
    // The receiver less every umbra, the largest first; what remains below 1e-12 of the
    // receiver's area is rounding along the seams.
    std::sort(umbrae.begin(), umbrae.end(),
              [](const Poly2& a, const Poly2& b) { return area2(a) > area2(b); });
    const double left_over = 1e-12 * std::abs(area2(whole));
    frags.clear();
    append2(frags, whole);
    if (area2(frags[0]) < 0.0) {
        std::reverse(frags[0].x.begin(), frags[0].x.begin() + frags[0].n);
        std::reverse(frags[0].y.begin(), frags[0].y.begin() + frags[0].n);
    }
    for (const Poly2& u : umbrae) {
        next.clear();
        for (const Poly2& f : frags) subtract(f, u, next);
        frags.clear();
        for (const Poly2& f : next)
            if (std::abs(area2(f)) > left_over) append2(frags, f);
        if (frags.empty()) return true;
    }
    return true;
}

// 1/A ∫ F(x → frags) dA_x over the cell [u0, u1] × [v0, v1] of the map m, by the tensor Gauss
// rule g of the given order (x in the sender's plane, normal ns; frags in the receiver's plane
// coordinates, in front of that plane): the smooth integrand of the umbra bounds. Scaled by `scale`
// (the cell's share of the unit square over the sender's area).
double fragments_rule(const SenderMap& m, double u0, double u1, double v0, double v1,
                      const GaussRule& g, int order, const Receiver& rc, const Vec3& ns,
                      const std::vector<Poly2>& frags, double scale) {
    const Vec3 nl(ns.dot(rc.u), ns.dot(rc.v), ns.dot(rc.n));
    const double q = tensor_rule(m, u0, u1, v0, v1, g, order, [&](double u, double v) {
        const Vec3 x = m.at(u, v);
        const Vec3 xr = x - rc.o;
        const Vec3 xl(rc.u.dot(xr), rc.v.dot(xr), rc.n.dot(x) - rc.d);
        double f = 0.0;  // 0 behind the receiver's plane
        if (xl.z() > 0.0)
            for (const Poly2& p : frags) f += lambert2(p, xl, nl);
        return f;
    });
    return q * scale;
}

}  // namespace

CellUmbra cell_umbra(const Receiver& rc, const SenderMap& m, double u0, double u1, double v0,
                     double v1, const Vec3* poly, int np, const Vec3& nx,
                     const BlockerSet& blockers, const int* cand, int count, double eps,
                     double scale, double give_up) {
    CellUmbra out;
    thread_local std::vector<Poly2> frags;
    if (!umbra_remainder(rc, poly, np, nx, blockers, cand, count, eps, frags)) return out;
    out.ok = true;
    out.hidden = frags.empty();
    if (out.hidden || std::isnan(give_up)) return out;
    const CellRules rules;
    const double q2 = fragments_rule(m, u0, u1, v0, v1, rules.g2, kLowOrder, rc, nx, frags, scale);
    if (q2 > give_up) {
        out.bound = q2;
        return out;
    }
    const double q3 = fragments_rule(m, u0, u1, v0, v1, rules.g3, kMidOrder, rc, nx, frags, scale);
    out.bound = q3 + kAgreement * std::abs(q3 - q2);
    return out;
}

VisibleBound visible_bound(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                           const int* cand, int n, double eps, double give_up, std::uint64_t seed) {
    VisibleBound out;
    const double area_s = area(s);
    const int np = static_cast<int>(s.size());
    if (!(area_s > 0.0) || n == 0 || np < 3 || np > 4) return out;
    const Vec3 ns = normal(s);
    const Receiver rc(r);
    SenderMap m;
    m.p0 = s[0];
    m.p1 = s[1];
    m.p2 = s[2];
    if (np == 4) {
        m.quad = true;
        m.p3 = s[3];
    } else {
        m.tri_j = (m.p1 - m.p0).cross(m.p2 - m.p1).norm();
    }
    // The whole sender as the one cell of its map.
    const CellUmbra cu = cell_umbra(rc, m, 0.0, 1.0, 0.0, 1.0, s.vertices.data(), np, ns, blockers,
                                    cand, n, eps, 1.0 / area_s, give_up);
    out.ok = cu.ok;
    out.bound = cu.bound;
    if (!cu.ok || cu.hidden || out.bound > give_up) return out;
    // What the sender sees past the blockers, at one point drawn in each quarter of the unit
    // square (stratified sampling: an unbiased estimate, inside the bound). The 2 × 2 Gauss
    // points fall at the same place in every pair of a row, and where the light is a sliver
    // along the umbrae's edges they missed it in all of them.
    const double seen = seen_at_drawn_points(rc, m, 0.0, 1.0, 0.0, 1.0, ns, blockers, cand, n, eps,
                                             seed, out.points);
    out.estimate = std::clamp(seen / area_s, 0.0, out.bound);
    return out;
}

bool seeing_part(const Polygon& s, const Polygon& r, const BlockerSet& blockers, const int* cand,
                 int n, double eps, std::vector<Polygon>& out) {
    out.clear();
    const int nr = static_cast<int>(r.size());
    if (nr < 3 || nr > 4 || s.size() > static_cast<std::size_t>(kCap)) return false;
    // r's corners as the cell, s as the receiver of the shadows.
    const Receiver onto(s);
    thread_local std::vector<Poly2> frags;
    if (!umbra_remainder(onto, r.vertices.data(), nr, normal(r), blockers, cand, n, eps, frags))
        return false;
    const Vec3 ns = normal(s);
    for (const Poly2& f : frags) {
        Polygon p;
        for (int k = 0; k < f.n; ++k)
            p.vertices.push_back(onto.o + f.x[static_cast<std::size_t>(k)] * onto.u +
                                 f.y[static_cast<std::size_t>(k)] * onto.v);
        if (normal(p).dot(ns) < 0.0) std::reverse(p.vertices.begin(), p.vertices.end());
        out.push_back(std::move(p));
    }
    return true;
}

double seen_at_drawn_points(const Receiver& rc, const SenderMap& m, double u0, double u1, double v0,
                            double v1, const Vec3& ns, const BlockerSet& blockers, const int* cand,
                            int n, double eps, std::uint64_t key, std::size_t& points) {
    const double du = u1 - u0, dv = v1 - v0;
    double seen = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            const auto at = static_cast<std::uint64_t>(2 * (2 * i + j));
            const double u = u0 + 0.5 * du * (i + uniform(key, at));
            const double v = v0 + 0.5 * dv * (j + uniform(key, at + 1));
            const PointResult pr = evaluate_point(rc, m.at(u, v), ns, blockers, cand, n, eps, true);
            ++points;
            seen += 0.25 * m.jacobian(u, v) * std::max(0.0, pr.unobstructed - pr.hidden);
        }
    return seen;
}

}  // namespace formfactor::detail
