// The sender of a partly hidden pair cut into convex pieces along the lines where the integrand
// F(x → hidden part of r) has kinks (discontinuity meshing, Heckbert 1992; Lischinski et al.
// 1992), so that hidden_integral() integrates smooth pieces. See docs/analytic.md, "Obstructed
// scenes".

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

namespace {

// An event line a u + b v = c ((a, b) unit) in the sender's plane coordinates; when bounded,
// only its segment p0 p1 matters.
struct Line {
    double a, b, c;
    bool bounded;
    Vec2 p0, p1;
};

// True when the segment of l meets the interior of the convex counter-clockwise polygon q (by
// more than tol): Cyrus–Beck clipping of the segment by q's edges.
bool segment_meets(const Line& l, const std::vector<Vec2>& q, double tol) {
    double t0 = 0.0, t1 = 1.0;
    const Vec2 d = l.p1 - l.p0;
    for (std::size_t k = 0; k < q.size(); ++k) {
        const Vec2& v0 = q[k];
        const Vec2 e = q[(k + 1) % q.size()] - v0;
        const double el = e.norm();
        if (!(el > 0.0)) continue;
        // Inside: cross(e, p − v0) ≥ tol·|e|.
        const double f0 = e.x() * (l.p0.y() - v0.y()) - e.y() * (l.p0.x() - v0.x()) - tol * el;
        const double fd = e.x() * d.y() - e.y() * d.x();
        if (fd == 0.0) {
            if (f0 < 0.0) return false;
            continue;
        }
        const double t = -f0 / fd;
        if (fd > 0.0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
        if (t0 > t1) return false;
    }
    return (t1 - t0) * d.norm() > tol;
}

}  // namespace

// The sender cut into convex pieces along the lines where F(x → hidden part of r) has kinks:
// the intersections of the sender's plane with the planes through a vertex of one polygon and
// an edge of another, among r and the candidate pieces (each clipped to the slab between the
// sender's and the receiver's planes). Across such a line a shadow vertex crosses an edge of the
// receiver or of another shadow (discontinuity meshing, Heckbert 1992; Lischinski et al. 1992);
// inside a piece the integrand is smooth but for the weaker edge-edge-edge events.
std::vector<Polygon> split_by_events(const Polygon& s, const Vec3& ns, const Receiver& rc,
                                     const BlockerSet& blockers, const int* cand, int n,
                                     double eps) {
    std::vector<Polygon> convex_s = BlockerSet::convex_parts(s);
    const double ds = ns.dot(s[0]);
    // The polygons whose vertices and edges make events.
    thread_local std::vector<Poly3> polys;
    // Per polygon: a bit per edge that cannot be a kink (an edge between two faces of a closed
    // solid that both face the whole sender: inside the union of the shadows).
    thread_local std::vector<std::uint64_t> inner;
    polys.clear();
    inner.clear();
    Poly3 a, b;
    clip3(rc.poly, ns, ds + eps, a);
    if (a.n >= 3) {
        polys.push_back(a);
        inner.push_back(0);
    }
    auto faces_sender = [&](int k) {
        const auto& pc = blockers.piece(k);
        if (!pc.cull_back) return false;
        for (const Vec3& v : s.vertices)
            if (!(pc.plane.signed_distance(v) > 0.0)) return false;
        return true;
    };
    for (int c = 0; c < n; ++c) {
        const auto& pc = blockers.piece(cand[c]);
        const Vec3* pv = blockers.vertices(cand[c]);
        if (pc.cull_back) {
            bool front = false;
            for (const Vec3& v : s.vertices) front = front || pc.plane.signed_distance(v) > 0.0;
            if (!front) continue;
        }
        a.n = pc.count;
        for (int k = 0; k < pc.count; ++k) a.v[static_cast<std::size_t>(k)] = pv[k];
        clip3(a, ns, ds, b);
        clip3(b, rc.n, rc.d, a);
        if (a.n < 3) continue;
        std::uint64_t mask = 0;
        if (a.n == pc.count && pc.count <= 64 && faces_sender(cand[c])) {
            bool same = true;
            for (int k = 0; k < pc.count && same; ++k)
                same = a.v[static_cast<std::size_t>(k)] == pv[k];
            for (int k = 0; k < pc.count && same; ++k) {
                const int nb = blockers.neighbor(cand[c], k);
                if (nb >= 0 && faces_sender(nb)) mask |= std::uint64_t{1} << k;
            }
        }
        polys.push_back(a);
        inner.push_back(mask);
    }
    if (polys.size() < 2) return convex_s;
    Vec3 su, sv;
    orthonormal_basis(ns, su, sv);
    const Vec3 o = s[0];
    const double tol = 1e-9 * diameter(s);

    thread_local std::vector<Line> lines;
    lines.clear();
    std::vector<Vec2> s2;
    for (const Vec3& v : s.vertices) s2.emplace_back(su.dot(v - o), sv.dot(v - o));
    for (std::size_t x = 0; x < polys.size(); ++x)
        for (int w = 0; w < polys[x].n; ++w) {
            // A vertex between two inner edges is inside the union too.
            const int wprev = w == 0 ? polys[x].n - 1 : w - 1;
            if ((inner[x] >> w & 1) && (inner[x] >> wprev & 1)) continue;
            const Vec3& pw = polys[x].v[static_cast<std::size_t>(w)];
            for (std::size_t y = 0; y < polys.size(); ++y) {
                if (y == x) continue;
                const Poly3& q = polys[y];
                for (int e = 0; e < q.n; ++e) {
                    if (inner[y] >> e & 1) continue;
                    const Vec3& e0 = q.v[static_cast<std::size_t>(e)];
                    const Vec3& e1 = q.v[static_cast<std::size_t>(e + 1 == q.n ? 0 : e + 1)];
                    const Vec3 m = (e1 - e0).cross(pw - e0);
                    const double la = m.dot(su), lb = m.dot(sv);
                    const double len = std::hypot(la, lb);
                    if (!(len > 1e-12 * m.norm()) || !(len > 0.0)) continue;
                    Line l{la / len, lb / len, m.dot(e0 - o) / len, true, {}, {}};
                    bool pos = false, neg = false;
                    for (const Vec2& p : s2) {
                        const double d = l.a * p.x() + l.b * p.y() - l.c;
                        pos = pos || d > tol;
                        neg = neg || d < -tol;
                    }
                    if (!(pos && neg)) continue;
                    // The event happens only on the projection of the edge through the vertex
                    // onto the sender's plane: x, w and a point of e collinear.
                    const double hw = ns.dot(pw) - ds, h0 = ns.dot(e0) - ds, h1 = ns.dot(e1) - ds;
                    const double d0 = hw - h0, d1 = hw - h1;
                    if (!(hw > 0.0)) continue;  // w on the sender's plane: no kink in front
                    if ((d0 > 0.0 && d1 > 0.0) || (d0 < 0.0 && d1 < 0.0)) {
                        const Vec3 x0 = pw + (e0 - pw) * (hw / d0) - o;
                        const Vec3 x1 = pw + (e1 - pw) * (hw / d1) - o;
                        l.bounded = true;
                        l.p0 = Vec2(su.dot(x0), sv.dot(x0));
                        l.p1 = Vec2(su.dot(x1), sv.dot(x1));
                        if (!segment_meets(l, s2, tol)) continue;
                    } else {
                        l.bounded = false;
                    }
                    lines.push_back(l);
                }
            }
        }
    if (lines.empty()) return convex_s;
    // Cut (in the sender's plane coordinates).
    std::vector<Poly2> cur, nxt;
    for (const Polygon& p : convex_s) {
        Poly2 q;
        q.n = static_cast<int>(p.size());
        for (std::size_t k = 0; k < p.size(); ++k) {
            q.x[k] = su.dot(p[k] - o);
            q.y[k] = sv.dot(p[k] - o);
        }
        cur.push_back(q);
    }
    constexpr std::size_t kMaxPieces = 256;
    thread_local std::vector<Vec2> scratch2;
    for (const Line& l : lines) {
        nxt.clear();
        for (const Poly2& q : cur) {
            bool pos = false, neg = false;
            for (int k = 0; k < q.n; ++k) {
                const double d = l.a * q.x[static_cast<std::size_t>(k)] +
                                 l.b * q.y[static_cast<std::size_t>(k)] - l.c;
                pos = pos || d > tol;
                neg = neg || d < -tol;
            }
            bool hit = pos && neg;
            if (hit && l.bounded) {
                std::vector<Vec2>& qv = scratch2;
                qv.clear();
                for (int k = 0; k < q.n; ++k)
                    qv.emplace_back(q.x[static_cast<std::size_t>(k)],
                                    q.y[static_cast<std::size_t>(k)]);
                hit = segment_meets(l, qv, tol);
            }
            if (!hit || cur.size() + nxt.size() >= kMaxPieces) {
                nxt.push_back(q);
                continue;
            }
            // A point on the line and its direction (b, −a).
            const double px = l.a * l.c, py = l.b * l.c;
            Poly2 left, right;
            clip2(q, px, py, l.b, -l.a, 1.0, left);
            clip2(q, px, py, l.b, -l.a, -1.0, right);
            if (left.n >= 3) nxt.push_back(left);
            if (right.n >= 3) nxt.push_back(right);
        }
        std::swap(cur, nxt);
    }
    std::vector<Polygon> out;
    for (const Poly2& q : cur) {
        Polygon p;
        for (int k = 0; k < q.n; ++k)
            p.vertices.push_back(o + q.x[static_cast<std::size_t>(k)] * su +
                                 q.y[static_cast<std::size_t>(k)] * sv);
        if (area(p) > 0.0) out.push_back(std::move(p));
    }
    return out;
}

}  // namespace formfactor::detail
