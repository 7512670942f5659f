// Obstructed form factors: convex blocker pieces in a BVH, conservative shaft tests, and the
// adaptive integration of the hidden part of partly hidden pairs (Walton's adaptive method,
// NISTIR 6925, with exact shadow polygons). See docs/analytic.md, "Obstructed scenes".

#include "formfactor/methods/obstructed.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numeric>
#include <queue>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor {
namespace detail {

namespace {

constexpr double kTwoPi = 2.0 * kPi;
// Capacity of the small polygons of the point evaluation: a convex piece (≤ kMaxPieceVertices)
// clipped by the receiver's plane and the pyramid's side planes gains one vertex per plane.
constexpr int kCap = 2 * kMaxPieceVertices + 8;

struct Poly3 {
    int n = 0;
    std::array<Vec3, kCap> v;
};
struct Poly2 {
    int n = 0;
    std::array<double, kCap> x, y;
};

bool is_convex(const Polygon& p, const Vec3& n) {
    const std::size_t m = p.size();
    if (m == 3) return true;
    const double scale = diameter(p);
    for (std::size_t k = 0; k < m; ++k) {
        const Vec3 e0 = p[k] - p[(k + m - 1) % m], e1 = p[(k + 1) % m] - p[k];
        if (e0.cross(e1).dot(n) < -1e-12 * scale * scale) return false;
    }
    return true;
}

// Convex pieces of a polygon: itself when convex and small, else its triangulation.
std::vector<Polygon> convex_pieces(const Polygon& p) {
    const Vec3 n = normal(p);
    if (p.size() <= static_cast<std::size_t>(kMaxPieceVertices) && is_convex(p, n)) return {p};
    std::vector<Polygon> out;
    for (const auto& t : triangulate(p)) {
        Polygon q;
        q.vertices = {p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                      p[static_cast<std::size_t>(t[2])]};
        if (area(q) > 0.0) out.push_back(std::move(q));
    }
    return out;
}

// Keeps the part of `in` where n·y − off ≥ 0 (Sutherland–Hodgman; convex in, convex out).
void clip3(const Poly3& in, const Vec3& n, double off, Poly3& out) {
    out.n = 0;
    if (in.n == 0) return;
    double d[kCap];
    bool all_in = true, all_out = true;
    for (int k = 0; k < in.n; ++k) {
        d[k] = n.dot(in.v[static_cast<std::size_t>(k)]) - off;
        all_in = all_in && d[k] >= 0.0;
        all_out = all_out && d[k] < 0.0;
    }
    if (all_out) return;
    if (all_in) {
        out.n = in.n;
        std::copy(in.v.begin(), in.v.begin() + in.n, out.v.begin());
        return;
    }
    for (int k = 0; k < in.n; ++k) {
        const int m = k + 1 == in.n ? 0 : k + 1;
        const Vec3& a = in.v[static_cast<std::size_t>(k)];
        if (d[k] >= 0.0 && out.n < kCap) out.v[static_cast<std::size_t>(out.n++)] = a;
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            if (out.n < kCap)
                out.v[static_cast<std::size_t>(out.n++)] =
                    a + t * (in.v[static_cast<std::size_t>(m)] - a);
        }
    }
    if (out.n < 3) out.n = 0;
}

void copy2(const Poly2& in, Poly2& out) {
    out.n = in.n;
    std::copy(in.x.begin(), in.x.begin() + in.n, out.x.begin());
    std::copy(in.y.begin(), in.y.begin() + in.n, out.y.begin());
}

// Keeps the part of `in` on the left of the directed line a → a + e (sign = +1) or on its right
// (sign = −1).
void clip2(const Poly2& in, double ax, double ay, double ex, double ey, double sign, Poly2& out) {
    out.n = 0;
    double d[kCap];
    bool all_in = true, all_out = true;
    for (int k = 0; k < in.n; ++k) {
        d[k] = sign * (ex * (in.y[static_cast<std::size_t>(k)] - ay) -
                       ey * (in.x[static_cast<std::size_t>(k)] - ax));
        all_in = all_in && d[k] >= 0.0;
        all_out = all_out && d[k] <= 0.0;
    }
    if (all_out) return;
    if (all_in) {
        copy2(in, out);
        return;
    }
    for (int k = 0; k < in.n; ++k) {
        const int m = k + 1 == in.n ? 0 : k + 1;
        const auto ks = static_cast<std::size_t>(k), ms = static_cast<std::size_t>(m);
        if (d[k] >= 0.0 && out.n < kCap) {
            out.x[static_cast<std::size_t>(out.n)] = in.x[ks];
            out.y[static_cast<std::size_t>(out.n++)] = in.y[ks];
        }
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            if (out.n < kCap) {
                out.x[static_cast<std::size_t>(out.n)] = in.x[ks] + t * (in.x[ms] - in.x[ks]);
                out.y[static_cast<std::size_t>(out.n++)] = in.y[ks] + t * (in.y[ms] - in.y[ks]);
            }
        }
    }
    if (out.n < 3) out.n = 0;
}

double area2(const Poly2& p) {
    double a = 0.0;
    for (int k = 0; k < p.n; ++k) {
        const int m = k + 1 == p.n ? 0 : k + 1;
        a += p.x[static_cast<std::size_t>(k)] * p.y[static_cast<std::size_t>(m)] -
             p.x[static_cast<std::size_t>(m)] * p.y[static_cast<std::size_t>(k)];
    }
    return 0.5 * a;
}

// f \ s for convex f and convex counter-clockwise s: disjoint convex fragments appended to out.
void subtract(const Poly2& f, const Poly2& s, std::vector<Poly2>& out) {
    Poly2 buf[2], outside;
    copy2(f, buf[0]);
    Poly2* inside = &buf[0];
    Poly2* next = &buf[1];
    for (int k = 0; k < s.n && inside->n >= 3; ++k) {
        const int m = k + 1 == s.n ? 0 : k + 1;
        const auto ks = static_cast<std::size_t>(k), ms = static_cast<std::size_t>(m);
        const double ax = s.x[ks], ay = s.y[ks];
        const double ex = s.x[ms] - ax, ey = s.y[ms] - ay;
        if (ex == 0.0 && ey == 0.0) continue;
        clip2(*inside, ax, ay, ex, ey, -1.0, outside);
        if (outside.n >= 3 && area2(outside) > 0.0) {
            out.emplace_back();
            copy2(outside, out.back());
        }
        clip2(*inside, ax, ay, ex, ey, 1.0, *next);
        std::swap(inside, next);
    }
}

// Lambert's formula for a counter-clockwise polygon q in the receiver's plane (local 2D
// coordinates), seen from the point xl = (u, v, height) with unit normal nl (local coordinates).
double lambert2(const Poly2& q, const Vec3& xl, const Vec3& nl) {
    double sum = 0.0;
    for (int k = 0; k < q.n; ++k) {
        const int m = k + 1 == q.n ? 0 : k + 1;
        const Vec3 r0(q.x[static_cast<std::size_t>(k)] - xl.x(),
                      q.y[static_cast<std::size_t>(k)] - xl.y(), -xl.z());
        const Vec3 r1(q.x[static_cast<std::size_t>(m)] - xl.x(),
                      q.y[static_cast<std::size_t>(m)] - xl.y(), -xl.z());
        const Vec3 cr = r0.cross(r1);
        const double len = cr.norm();
        if (len == 0.0) continue;
        sum += std::atan2(len, r0.dot(r1)) * nl.dot(cr) / len;
    }
    return std::max(0.0, -sum / kTwoPi);
}

// The receiver of a pair, prepared once: convex polygon and its plane frame.
struct Receiver {
    Poly3 poly;
    Vec3 n, o, u, v;
    double d = 0;
    explicit Receiver(const Polygon& r) {
        FF_ASSERT(r.size() <= static_cast<std::size_t>(kCap));
        poly.n = static_cast<int>(r.size());
        for (std::size_t k = 0; k < r.size(); ++k) poly.v[k] = r[k];
        n = normal(r);
        o = r[0];
        d = n.dot(o);
        orthonormal_basis(n, u, v);
    }
};

struct PointResult {
    double hidden = 0.0;
    double unobstructed = 0.0;  // F(x → r), when asked for
};

// F(x → part of the receiver hidden by the candidate pieces); see point_hidden().
PointResult evaluate_point(const Receiver& rc, const Vec3& x, const Vec3& nx,
                           const BlockerSet& blockers, const int* cand, int count, double eps,
                           bool want_unobstructed) {
    PointResult res;
    const double h = rc.n.dot(x) - rc.d;
    if (!(h > 0.0)) return res;
    Poly3 rp;
    clip3(rc.poly, nx, nx.dot(x), rp);
    if (rp.n < 3) return res;
    const Vec3 xr = x - rc.o;
    const Vec3 xl(rc.u.dot(xr), rc.v.dot(xr), h);
    const Vec3 nl(nx.dot(rc.u), nx.dot(rc.v), nx.dot(rc.n));
    if (want_unobstructed) {
        Poly2 q;
        q.n = rp.n;
        for (int k = 0; k < rp.n; ++k) {
            const Vec3 w = rp.v[static_cast<std::size_t>(k)] - rc.o;
            q.x[static_cast<std::size_t>(k)] = rc.u.dot(w);
            q.y[static_cast<std::size_t>(k)] = rc.v.dot(w);
        }
        res.unobstructed = lambert2(q, xl, nl);
    }
    if (count == 0) return res;
    // Inward side planes of the pyramid from x over the visible receiver.
    std::array<Vec3, kCap> side;
    std::array<double, kCap> side_off;
    int sides = 0;
    for (int k = 0; k < rp.n; ++k) {
        const int m = k + 1 == rp.n ? 0 : k + 1;
        const Vec3 s =
            (rp.v[static_cast<std::size_t>(m)] - x).cross(rp.v[static_cast<std::size_t>(k)] - x);
        const double len = s.norm();
        if (!(len > 0.0)) continue;
        side[static_cast<std::size_t>(sides)] = s / len;
        side_off[static_cast<std::size_t>(sides)] = side[static_cast<std::size_t>(sides)].dot(x);
        ++sides;
    }
    thread_local std::vector<Poly2> shadows, frags, next;
    shadows.clear();
    Poly3 buf[2];
    for (int c = 0; c < count; ++c) {
        const int pk = cand[c];
        const auto& pc = blockers.piece(pk);
        if (pc.cull_back && !(pc.plane.signed_distance(x) > 0.0)) continue;
        const Vec3* pv = blockers.vertices(pk);
        Poly3* a = &buf[0];
        Poly3* bp = &buf[1];
        a->n = pc.count;
        for (int k = 0; k < pc.count; ++k) a->v[static_cast<std::size_t>(k)] = pv[k];
        // Between x and the receiver's plane (a piece within eps of that plane hides nothing).
        clip3(*a, rc.n, rc.d + eps, *bp);
        for (int s = 0; s < sides && bp->n >= 3; ++s) {
            clip3(*bp, side[static_cast<std::size_t>(s)], side_off[static_cast<std::size_t>(s)],
                  *a);
            std::swap(a, bp);
        }
        const Poly3& b = *bp;
        if (b.n < 3) continue;
        shadows.emplace_back();
        Poly2& q = shadows.back();
        q.n = b.n;
        for (int k = 0; k < b.n; ++k) {
            const Vec3& y = b.v[static_cast<std::size_t>(k)];
            const double den = h - (rc.n.dot(y) - rc.d);
            const double t = den > 1e-300 ? h / den : 1e300;
            const Vec3 w = x + t * (y - x) - rc.o;
            q.x[static_cast<std::size_t>(k)] = rc.u.dot(w);
            q.y[static_cast<std::size_t>(k)] = rc.v.dot(w);
        }
        const double ar = area2(q);
        if (ar == 0.0 || !std::isfinite(ar)) {
            shadows.pop_back();
            continue;
        }
        if (ar < 0.0) {
            std::reverse(q.x.begin(), q.x.begin() + q.n);
            std::reverse(q.y.begin(), q.y.begin() + q.n);
        }
    }
    // Union of the shadows as disjoint convex fragments: shadow k minus shadows 0..k−1.
    // Fragments below 1e-14 of the receiver's size² are rounding slivers of the subtraction.
    const double tiny_area = 1e-14 * (rp.v[0] - rp.v[2]).squaredNorm();
    for (std::size_t k = 0; k < shadows.size(); ++k) {
        frags.clear();
        frags.emplace_back();
        copy2(shadows[k], frags.back());
        for (std::size_t l = 0; l < k && !frags.empty(); ++l) {
            next.clear();
            for (const Poly2& f : frags) subtract(f, shadows[l], next);
            std::swap(frags, next);
        }
        for (const Poly2& f : frags)
            if (area2(f) > tiny_area) res.hidden += lambert2(f, xl, nl);
    }
    return res;
}

// Cells where the shaft test finds a blocker but no sample point sees a shadow get their whole
// unobstructed contribution as the error estimate (forcing subdivision) down to this level; below
// it such a shadow is a sliver along a shadow boundary, whose part the normal estimate covers.
constexpr int kSuspiciousLevels = 4;

// The tensor Gauss–Legendre rules of a cell: the result is the highest order's, the larger
// difference between consecutive orders its error estimate.
constexpr int kLowOrder = 2, kMidOrder = 3, kHighOrder = 4;
struct CellRules {
    const GaussRule& g2 = gauss_legendre01(kLowOrder);
    const GaussRule& g3 = gauss_legendre01(kMidOrder);
    const GaussRule& g4 = gauss_legendre01(kHighOrder);
};

// A convex piece of the sender mapped from the unit square: a quad by its bilinear map, a
// triangle by the collapsed (Duffy) map.
struct SenderMap {
    Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero(), p2 = Vec3::Zero(), p3 = Vec3::Zero();
    bool quad = false;
    double tri_j = 0;  // |(B − A) × (C − B)| for the triangle map
    Vec3 at(double u, double v) const {
        if (quad) return (1 - u) * (1 - v) * p0 + u * (1 - v) * p1 + u * v * p2 + (1 - u) * v * p3;
        return p0 + u * (p1 - p0) + u * v * (p2 - p1);
    }
    double jacobian(double u, double v) const {
        if (quad) {
            const Vec3 pu = (1 - v) * (p1 - p0) + v * (p2 - p3);
            const Vec3 pv = (1 - u) * (p3 - p0) + u * (p2 - p1);
            return pu.cross(pv).norm();
        }
        return tri_j * u;
    }
};

struct Cell {
    int map = 0;
    double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
    int level = 0;
    double value = 0, error = 0;
};

}  // namespace

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

}  // namespace

// ----------------------------------------------------------------------------------------------
// BlockerSet

std::vector<Polygon> BlockerSet::convex_parts(const Polygon& p) { return convex_pieces(p); }

void BlockerSet::add(const Polygon& p, int surface) {
    for (const Polygon& q : convex_pieces(p)) {
        Piece pc;
        pc.first = static_cast<int>(verts_.size());
        pc.count = static_cast<int>(q.size());
        pc.plane = plane_of(q);
        pc.box = bounds(q);
        pc.surface = surface;
        for (const Vec3& v : q.vertices) verts_.push_back(v);
        pieces_.push_back(pc);
    }
}

void BlockerSet::build() {
    nodes_.clear();
    order_.resize(pieces_.size());
    std::iota(order_.begin(), order_.end(), 0);
    if (!pieces_.empty()) build_node(0, static_cast<int>(pieces_.size()));
}

void BlockerSet::mark_closed_solids(const std::vector<std::pair<Bounds3, int>>& patches,
                                    double tol) {
    const std::size_t np = pieces_.size();
    auto key = [&](const Vec3& v) {
        return std::array<long long, 3>{std::llround(v.x() / tol), std::llround(v.y() / tol),
                                        std::llround(v.z() / tol)};
    };
    using EdgeKey = std::array<long long, 6>;
    std::map<EdgeKey, std::vector<int>> edges;  // directed edge → pieces
    for (std::size_t p = 0; p < np; ++p) {
        const Piece& pc = pieces_[p];
        for (int k = 0; k < pc.count; ++k) {
            const auto a = key(verts_[static_cast<std::size_t>(pc.first + k)]);
            const auto b = key(verts_[static_cast<std::size_t>(pc.first + (k + 1) % pc.count)]);
            edges[{a[0], a[1], a[2], b[0], b[1], b[2]}].push_back(static_cast<int>(p));
        }
    }
    // Union–find over pieces joined by reversed edges; a piece with an unmatched edge is open.
    std::vector<int> parent(np);
    std::iota(parent.begin(), parent.end(), 0);
    std::function<int(int)> find = [&](int x) {
        while (parent[static_cast<std::size_t>(x)] != x)
            x = parent[static_cast<std::size_t>(x)] =
                parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
        return x;
    };
    std::vector<char> open(np, 0);
    for (const auto& [e, ps] : edges) {
        const EdgeKey rev = {e[3], e[4], e[5], e[0], e[1], e[2]};
        const auto it = edges.find(rev);
        if (it == edges.end() || ps.size() != 1 || it->second.size() != 1) {
            for (int p : ps) open[static_cast<std::size_t>(p)] = 1;
            continue;
        }
        parent[static_cast<std::size_t>(find(ps[0]))] = find(it->second[0]);
    }
    std::map<int, std::vector<int>> comps;
    for (std::size_t p = 0; p < np; ++p)
        comps[find(static_cast<int>(p))].push_back(static_cast<int>(p));
    for (const auto& [root, ps] : comps) {
        (void)root;
        bool closed = ps.size() >= 4;
        double volume = 0.0;
        Bounds3 box;
        std::vector<int> ids;
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            closed = closed && !open[static_cast<std::size_t>(p)];
            const Vec3& v0 = verts_[static_cast<std::size_t>(pc.first)];
            for (int k = 1; k + 1 < pc.count; ++k)
                volume += v0.dot(verts_[static_cast<std::size_t>(pc.first + k)].cross(
                              verts_[static_cast<std::size_t>(pc.first + k + 1)])) /
                          6.0;
            box.extend(pc.box.lo);
            box.extend(pc.box.hi);
            ids.push_back(pc.surface);
        }
        if (!closed || !(volume > 0.0)) continue;
        std::sort(ids.begin(), ids.end());
        bool empty_inside = true;
        for (const auto& [pb, id] : patches) {
            if (std::binary_search(ids.begin(), ids.end(), id)) continue;
            if ((pb.lo.array() <= box.hi.array() + tol).all() &&
                (pb.hi.array() >= box.lo.array() - tol).all()) {
                empty_inside = false;
                break;
            }
        }
        if (!empty_inside) continue;
        for (int p : ps) pieces_[static_cast<std::size_t>(p)].cull_back = true;
        if (neighbor_.empty()) neighbor_.assign(verts_.size(), -1);
        for (int p : ps) {
            const Piece& pc = pieces_[static_cast<std::size_t>(p)];
            for (int k = 0; k < pc.count; ++k) {
                const auto a = key(verts_[static_cast<std::size_t>(pc.first + k)]);
                const auto b = key(verts_[static_cast<std::size_t>(pc.first + (k + 1) % pc.count)]);
                const auto it = edges.find({b[0], b[1], b[2], a[0], a[1], a[2]});
                neighbor_[static_cast<std::size_t>(pc.first + k)] = it->second[0];
            }
        }
    }
}

int BlockerSet::build_node(int first, int count) {
    const int id = static_cast<int>(nodes_.size());
    nodes_.push_back({});
    Bounds3 box, cbox;
    for (int k = first; k < first + count; ++k) {
        const Piece& p = pieces_[static_cast<std::size_t>(order_[static_cast<std::size_t>(k)])];
        box.extend(p.box.lo);
        box.extend(p.box.hi);
        cbox.extend(0.5 * (p.box.lo + p.box.hi));
    }
    nodes_[static_cast<std::size_t>(id)].box = box;
    if (count <= 4) {
        nodes_[static_cast<std::size_t>(id)].first = first;
        nodes_[static_cast<std::size_t>(id)].count = count;
        return id;
    }
    int axis = 0;
    const Vec3 ext = cbox.diagonal();
    if (ext.y() > ext[axis]) axis = 1;
    if (ext.z() > ext[axis]) axis = 2;
    const int mid = first + count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count,
                     [&](int a, int b) {
                         const Piece& pa = pieces_[static_cast<std::size_t>(a)];
                         const Piece& pb = pieces_[static_cast<std::size_t>(b)];
                         return pa.box.lo[axis] + pa.box.hi[axis] <
                                pb.box.lo[axis] + pb.box.hi[axis];
                     });
    const int l = build_node(first, mid - first);
    const int r = build_node(mid, first + count - mid);
    nodes_[static_cast<std::size_t>(id)].left = l;
    nodes_[static_cast<std::size_t>(id)].right = r;
    return id;
}

void BlockerSet::query(const Shaft& shaft, int skip_a, int skip_b, std::vector<int>& out) const {
    if (nodes_.empty()) return;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& nd = nodes_[static_cast<std::size_t>(stack[--top])];
        if (shaft.box_outside(nd.box)) continue;
        if (nd.left < 0) {
            for (int k = nd.first; k < nd.first + nd.count; ++k) {
                const int p = order_[static_cast<std::size_t>(k)];
                const int s = pieces_[static_cast<std::size_t>(p)].surface;
                if (s == skip_a || s == skip_b) continue;
                out.push_back(p);
            }
        } else if (top + 2 <= 128) {
            stack[top++] = nd.left;
            stack[top++] = nd.right;
        }
    }
}

// ----------------------------------------------------------------------------------------------
// Shaft

void Shaft::build(const Vec3* a, int na, const Vec3& normal_a, const Vec3* b, int nb,
                  const Vec3& normal_b, double eps) {
    a_ = a;
    b_ = b;
    na_ = na;
    nb_ = nb;
    eps_ = eps;
    pa_ = {normal_a, normal_a.dot(a[0])};
    pb_ = {normal_b, normal_b.dot(b[0])};
    bool b_front = false, a_front = false;
    for (int k = 0; k < nb; ++k) b_front = b_front || pa_.signed_distance(b[k]) > eps;
    for (int k = 0; k < na; ++k) a_front = a_front || pb_.signed_distance(a[k]) > eps;
    facing_away_ = !a_front || !b_front;
    sides_ = 0;
    links_ = 0;
    ca_ = cb_ = Vec3::Zero();
    for (int k = 0; k < na; ++k) ca_ += a[k];
    for (int k = 0; k < nb; ++k) cb_ += b[k];
    ca_ /= na;
    cb_ /= nb;
    // Side faces of the hull: through an edge of one polygon and a vertex of the other, with
    // every vertex of both on one side.
    auto sides_of = [&](const Vec3* p, int np, const Vec3& own, const Vec3& pc, const Vec3* q,
                        int nq) {
        for (int k = 0; k < np; ++k) {
            const Vec3& e0 = p[k];
            const Vec3 t = p[k + 1 == np ? 0 : k + 1] - e0;
            // When q is in front of p's plane, the face through this edge is the plane through
            // the vertex of q with the smallest angle above p's plane, seen along the edge
            // (angles compared by cross products, in the section across the edge, x pointing
            // out of p, y along p's normal).
            {
                Vec3 r = t.cross(own);
                if (r.dot(pc - e0) > 0.0) r = -r;
                int best = -1;
                double best_angle = 0.0, by = 0.0;
                bool front = true;
                const double tn = t.norm();
                for (int w = 0; w < nq && front; ++w) {
                    const Vec3 d = q[w] - e0;
                    const double x = r.dot(d) / tn, y = own.dot(d);
                    if (y < -eps) front = false;
                    // On the edge's line (distance from the line, not the cross-section
                    // coordinates: `own` is not exactly normal to an edge of a slightly
                    // non-planar polygon).
                    if ((d - t * (t.dot(d) / (tn * tn))).squaredNorm() <= eps * eps) continue;
                    // The angle above p's plane, in [0, π]: a cross-product comparison cannot
                    // order two directions 180° apart (vertices of q in p's plane on both sides
                    // of the edge, as where a wall meets the floor).
                    const double angle = std::atan2(std::max(y, 0.0), x);
                    if (best < 0 || angle < best_angle) {
                        best = w;
                        best_angle = angle;
                        by = y;
                    }
                }
                if (front) {
                    Vec3 m = best >= 0 ? t.cross(q[best] - e0) : Vec3::Zero();
                    const double mlen = m.norm();
                    if (best >= 0 && by > eps && mlen > 1e-9 * tn * (q[best] - e0).norm()) {
                        m /= mlen;
                        double off = m.dot(e0);
                        if (m.dot(pc) - off > 0.0) {
                            m = -m;
                            off = -off;
                        }
                        side_[sides_++] = Plane{m, off};
                        link_[links_++] = q[best] - e0;
                        link_[links_++] = q[best] - p[k + 1 == np ? 0 : k + 1];
                    }
                    continue;
                }
            }
            for (int w = 0; w < nq; ++w) {
                Vec3 m = t.cross(q[w] - e0);
                const double len = m.norm();
                if (!(len > 1e-300)) continue;
                m /= len;
                // p's own plane (already a bound) is no side face.
                if (std::abs(m.dot(own)) > 1.0 - 1e-12) continue;
                const double off = m.dot(e0);
                double lo = 0.0, hi = 0.0;
                for (int j = 0; j < nq && !(lo < -eps && hi > eps); ++j) {
                    const double s = m.dot(q[j]) - off;
                    lo = std::min(lo, s);
                    hi = std::max(hi, s);
                }
                for (int j = 0; j < np && !(lo < -eps && hi > eps); ++j) {
                    const double s = m.dot(p[j]) - off;
                    lo = std::min(lo, s);
                    hi = std::max(hi, s);
                }
                if (hi <= eps || lo >= -eps) {
                    side_[sides_++] = hi <= eps ? Plane{m, off} : Plane{-m, -off};
                    link_[links_++] = q[w] - e0;
                    link_[links_++] = q[w] - p[k + 1 == np ? 0 : k + 1];
                    break;
                }
            }
        }
    };
    sides_of(a, na, normal_a, ca_, b, nb);
    sides_of(b, nb, normal_b, cb_, a, na);
    // A side plane that cuts off a vertex of either polygon would make the shaft smaller than
    // the hull (not conservative): drop it (fewer planes only enlarge the shaft).
    int kept = 0;
    for (int k = 0; k < sides_; ++k) {
        bool ok = std::abs(side_[k].n.squaredNorm() - 1.0) < 1e-9 && std::isfinite(side_[k].d);
        for (int i = 0; i < na && ok; ++i) ok = side_[k].signed_distance(a[i]) <= eps;
        for (int j = 0; j < nb && ok; ++j) ok = side_[k].signed_distance(b[j]) <= eps;
        if (ok) side_[kept++] = side_[k];
    }
    sides_ = kept;
}

bool Shaft::box_outside(const Bounds3& box) const {
    const Vec3 c = 0.5 * (box.lo + box.hi), e = 0.5 * (box.hi - box.lo);
    auto range = [&](const Plane& p, double& lo, double& hi) {
        const double s = p.signed_distance(c);
        const double r =
            std::abs(p.n.x()) * e.x() + std::abs(p.n.y()) * e.y() + std::abs(p.n.z()) * e.z();
        lo = s - r;
        hi = s + r;
    };
    double lo, hi;
    range(pa_, lo, hi);
    if (hi <= eps_) return true;
    range(pb_, lo, hi);
    if (hi <= eps_) return true;
    for (int k = 0; k < sides_; ++k) {
        range(side_[k], lo, hi);
        if (lo >= -eps_) return true;
    }
    return false;
}

bool Shaft::piece_outside(const Vec3* p, int count, const Plane& pl, bool exact) const {
    double hi_a = -1e300, hi_b = -1e300;
    for (int k = 0; k < count; ++k) {
        hi_a = std::max(hi_a, pa_.signed_distance(p[k]));
        hi_b = std::max(hi_b, pb_.signed_distance(p[k]));
    }
    if (hi_a <= eps_ || hi_b <= eps_) return true;
    for (int s = 0; s < sides_; ++s) {
        double lo = 1e300;
        for (int k = 0; k < count && lo >= -eps_; ++k)
            lo = std::min(lo, side_[s].signed_distance(p[k]));
        if (lo >= -eps_) return true;
    }
    double lo = 1e300, hi = -1e300;
    for (int k = 0; k < na_; ++k) {
        const double s = pl.signed_distance(a_[k]);
        lo = std::min(lo, s);
        hi = std::max(hi, s);
    }
    for (int k = 0; k < nb_; ++k) {
        const double s = pl.signed_distance(b_[k]);
        lo = std::min(lo, s);
        hi = std::max(hi, s);
    }
    if (lo >= -eps_ || hi <= eps_) return true;
    if (!exact) return false;
    // The segment between the polygons' centres crosses the piece: it certainly blocks.
    {
        const double s0 = pl.signed_distance(ca_), s1 = pl.signed_distance(cb_);
        if ((s0 > eps_ && s1 < -eps_) || (s0 < -eps_ && s1 > eps_)) {
            const Vec3 z = ca_ + (cb_ - ca_) * (s0 / (s0 - s1));
            bool inside = true;
            for (int k = 0; k < count && inside; ++k) {
                const Vec3 e = p[k + 1 == count ? 0 : k + 1] - p[k];
                inside = e.cross(z - p[k]).dot(pl.n) > eps_ * e.norm();
            }
            if (inside) return false;
        }
    }
    // Separating axis theorem for the remaining axes: an edge of the piece crossed with an edge
    // of the hull (a's and b's edges, and the edges of the side faces between them).
    auto separated = [&](const Vec3& axis) {
        const double len = axis.norm();
        if (!(len > 0.0)) return false;
        double lo1 = 1e300, hi1 = -1e300, lo2 = 1e300, hi2 = -1e300;
        for (int k = 0; k < na_; ++k) {
            const double t = axis.dot(a_[k]);
            lo1 = std::min(lo1, t);
            hi1 = std::max(hi1, t);
        }
        for (int k = 0; k < nb_; ++k) {
            const double t = axis.dot(b_[k]);
            lo1 = std::min(lo1, t);
            hi1 = std::max(hi1, t);
        }
        for (int k = 0; k < count; ++k) {
            const double t = axis.dot(p[k]);
            lo2 = std::min(lo2, t);
            hi2 = std::max(hi2, t);
        }
        const double m = eps_ * len;
        return hi2 <= lo1 + m || hi1 <= lo2 + m;
    };
    for (int k = 0; k < count; ++k) {
        const Vec3 e = p[k + 1 == count ? 0 : k + 1] - p[k];
        for (int i = 0; i < na_; ++i)
            if (separated(e.cross(a_[i + 1 == na_ ? 0 : i + 1] - a_[i]))) return true;
        for (int j = 0; j < nb_; ++j)
            if (separated(e.cross(b_[j + 1 == nb_ ? 0 : j + 1] - b_[j]))) return true;
        for (int l = 0; l < links_; ++l)
            if (separated(e.cross(link_[l]))) return true;
    }
    return false;
}

bool Shaft::piece_hides(const Vec3* p, int count, const Plane& pl) const {
    // The piece's plane must separate a and b strictly; then every segment crosses it inside the
    // convex hull of the vertex-to-vertex crossings, which must lie inside the piece.
    double sa[kCap], sb[kCap];
    if (na_ > kCap || nb_ > kCap) return false;
    double sign = 0.0;
    for (int k = 0; k < na_; ++k) sa[k] = pl.signed_distance(a_[k]);
    for (int k = 0; k < nb_; ++k) sb[k] = pl.signed_distance(b_[k]);
    sign = sa[0] > 0.0 ? 1.0 : -1.0;
    for (int k = 0; k < na_; ++k)
        if (!(sign * sa[k] > eps_)) return false;
    for (int k = 0; k < nb_; ++k)
        if (!(-sign * sb[k] > eps_)) return false;
    for (int i = 0; i < na_; ++i) {
        for (int j = 0; j < nb_; ++j) {
            const double t = sa[i] / (sa[i] - sb[j]);
            const Vec3 z = a_[i] + t * (b_[j] - a_[i]);
            for (int k = 0; k < count; ++k) {
                const Vec3& v0 = p[k];
                const Vec3 e = p[k + 1 == count ? 0 : k + 1] - v0;
                const double len = e.norm();
                if (e.cross(z - v0).dot(pl.n) < eps_ * len) return false;
            }
        }
    }
    return true;
}

ShaftClass classify_shaft(const Shaft& shaft, const BlockerSet& blockers, const int* cand, int n,
                          std::vector<int>& kept, bool exact) {
    kept.clear();
    for (int c = 0; c < n; ++c) {
        const int k = cand[c];
        const auto& pc = blockers.piece(k);
        const Vec3* v = blockers.vertices(k);
        if (shaft.piece_outside(v, pc.count, pc.plane, exact)) continue;
        if (shaft.piece_hides(v, pc.count, pc.plane)) {
            kept.clear();
            return ShaftClass::kHidden;
        }
        kept.push_back(k);
    }
    return kept.empty() ? ShaftClass::kVisible : ShaftClass::kPartial;
}

std::vector<Vec3> planar_convex_hull(const std::vector<Vec3>& points, const Vec3& n) {
    if (points.size() < 3) return points;
    Vec3 u, v;
    orthonormal_basis(n, u, v);
    const Vec3 o = points[0];
    struct P2 {
        double x, y;
        int k;
    };
    std::vector<P2> p;
    p.reserve(points.size());
    for (std::size_t k = 0; k < points.size(); ++k)
        p.push_back({u.dot(points[k] - o), v.dot(points[k] - o), static_cast<int>(k)});
    std::sort(p.begin(), p.end(),
              [](const P2& a, const P2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    auto cross = [](const P2& o2, const P2& a, const P2& b) {
        return (a.x - o2.x) * (b.y - o2.y) - (a.y - o2.y) * (b.x - o2.x);
    };
    std::vector<P2> h(2 * p.size());
    std::size_t m = 0;
    for (std::size_t k = 0; k < p.size(); ++k) {
        while (m >= 2 && cross(h[m - 2], h[m - 1], p[k]) <= 0) --m;
        h[m++] = p[k];
    }
    for (std::size_t k = p.size() - 1, t = m + 1; k-- > 0;) {
        while (m >= t && cross(h[m - 2], h[m - 1], p[k]) <= 0) --m;
        h[m++] = p[k];
    }
    h.resize(m > 0 ? m - 1 : 0);
    std::vector<Vec3> out;
    for (const P2& q : h) out.push_back(points[static_cast<std::size_t>(q.k)]);
    return out;
}

double point_hidden(const Vec3& x, const Vec3& n, const Polygon& r, const BlockerSet& blockers,
                    const int* cand, int count, double eps, double* unobstructed) {
    const Receiver rc(r);
    const PointResult res =
        evaluate_point(rc, x, n, blockers, cand, count, eps, unobstructed != nullptr);
    if (unobstructed) *unobstructed = res.unobstructed;
    return std::min(res.hidden, unobstructed ? res.unobstructed : res.hidden);
}

HiddenIntegral hidden_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                               const int* cand, int n, double target, double eps) {
    HiddenIntegral out;
    const double area_s = area(s);
    if (!(area_s > 0.0) || n == 0) return out;
    const Vec3 ns = normal(s);
    const Receiver rc(r);
    // Sender pieces: the sender cut along the lines where the integrand has kinks, then
    // triangles (or the sender's own quad when nothing cuts it).
    const std::vector<Polygon> pieces = split_by_events(s, ns, rc, blockers, cand, n, eps);
    // Each convex piece is mapped from the unit square by quads (0, k, k+1, k+2) of its fan
    // (convex, as parts of a convex polygon) and a last triangle when the count is odd: half
    // the maps, so half the cells, of a fan of triangles. Slivers below 1e-12 of the sender
    // (rounding pieces of the cut) are not integrated: F(x → r) ≤ 1 bounds what they hold,
    // and that bound goes into the error.
    std::vector<SenderMap> maps;
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
    std::vector<int> cell_cand;
    const double inv_area = 1.0 / area_s;

    auto process = [&](Cell& c) {
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
        Shaft sh;
        sh.build(poly, np, ns, rc.poly.v.data(), rc.poly.n, rc.n, eps);
        if (sh.facing_away()) return;
        const ShaftClass cls = classify_shaft(sh, blockers, cand, n, kept, false);
        if (cls == ShaftClass::kVisible) return;
        // Pieces that face the cell first: the shadows of the others (the back faces of a closed
        // solid) then mostly vanish in the union.
        cell_cand.clear();
        const Vec3 mid = m.at(0.5 * (c.u0 + c.u1), 0.5 * (c.v0 + c.v1));
        for (int pass = 0; pass < 2; ++pass)
            for (int k : kept)
                if ((blockers.piece(k).plane.signed_distance(mid) > 0.0) == (pass == 0))
                    cell_cand.push_back(k);
        const double du = c.u1 - c.u0, dv = c.v1 - c.v0;
        double q2 = 0.0, q3 = 0.0, u3 = 0.0;
        bool any_hidden = false;
        const bool hidden = cls == ShaftClass::kHidden;
        auto f = [&](double u, double v, bool need_unobs) {
            const Vec3 x = m.at(u, v);
            const PointResult pr =
                evaluate_point(rc, x, ns, blockers, cell_cand.data(),
                               hidden ? 0 : static_cast<int>(cell_cand.size()), eps, need_unobs);
            ++out.points;
            return pr;
        };
        // Tensor Gauss rules of orders 2, 3 and 4 (29 points): the order-4 value, the larger of
        // the two differences its error estimate. Two low orders alone can agree by chance while
        // both are off (seen: orders 2 and 3 within 4e-8 of each other and 1.75e-6 from the
        // integral, which order 4 gets to 1.2e-7); three rules must all agree.
        const double scale = du * dv * inv_area;
        double q4 = 0.0;
        auto rule = [&](const GaussRule& g, int order, double& q) {
            for (int i = 0; i < order; ++i)
                for (int j = 0; j < order; ++j) {
                    const double u = c.u0 + du * g.x[static_cast<std::size_t>(i)];
                    const double v = c.v0 + dv * g.x[static_cast<std::size_t>(j)];
                    const PointResult pr = f(u, v, hidden);
                    const double val = hidden ? pr.unobstructed : pr.hidden;
                    any_hidden = any_hidden || pr.hidden > 0.0;
                    q += g.w[static_cast<std::size_t>(i)] * g.w[static_cast<std::size_t>(j)] *
                         m.jacobian(u, v) * val;
                }
        };
        rule(rules.g2, kLowOrder, q2);
        rule(rules.g3, kMidOrder, q3);
        if (std::abs(q3 - q2) * scale > target) {
            // The cell alone exceeds the pair's target: it will be split whatever order 4
            // says, and its estimate is at least this difference.
            c.value = q3 * scale;
            c.error = std::abs(q3 - q2) * scale;
        } else {
            rule(rules.g4, kHighOrder, q4);
            c.value = q4 * scale;
            c.error = std::max(std::abs(q4 - q3), std::abs(q3 - q2)) * scale;
        }
        // Partly hidden by its shaft, yet no sample point sees a shadow: the shadow may fall
        // between the points; what it can hide is at most the cell's unobstructed part.
        if (!hidden && !any_hidden && c.level < kSuspiciousLevels) {
            // Unless the exact test finds that no piece meets the cell's shaft after all.
            bool meets = false;
            for (int k : cell_cand) {
                const auto& pc = blockers.piece(k);
                if (!sh.piece_outside(blockers.vertices(k), pc.count, pc.plane, true)) {
                    meets = true;
                    break;
                }
            }
            if (meets) {
                // What the cell sees of the receiver: a bound on what a shadow can hide.
                for (std::size_t i = 0; i < kMidOrder; ++i)
                    for (std::size_t j = 0; j < kMidOrder; ++j) {
                        const double u = c.u0 + du * rules.g3.x[i], v = c.v0 + dv * rules.g3.x[j];
                        const PointResult pr =
                            evaluate_point(rc, m.at(u, v), ns, blockers, nullptr, 0, eps, true);
                        u3 += rules.g3.w[i] * rules.g3.w[j] * m.jacobian(u, v) * pr.unobstructed;
                    }
                c.error = std::max(c.error, u3 * scale);
            }
        }
    };

    auto worse = [](const Cell& a, const Cell& b) { return a.error < b.error; };
    std::vector<Cell> heap;
    double total_error = 0.0;
    for (std::size_t k = 0; k < maps.size(); ++k) {
        Cell c;
        c.map = static_cast<int>(k);
        process(c);
        total_error += c.error;
        heap.push_back(c);
    }
    std::make_heap(heap.begin(), heap.end(), worse);
    constexpr std::size_t kMaxCells = 4096;
    constexpr int kMaxLevel = 14;
    std::vector<Cell> done;
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
        total_error -= c.error;
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
                process(ch);
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
    }
    out.error = err + sliver_error;
    out.cells = done.size();
    return out;
}

}  // namespace detail

// ----------------------------------------------------------------------------------------------
// Public functions

namespace {

detail::BlockerSet make_blockers(const std::vector<Polygon>& blockers) {
    detail::BlockerSet set;
    for (std::size_t k = 0; k < blockers.size(); ++k) set.add(blockers[k], static_cast<int>(k));
    set.build();
    return set;
}

double pair_eps(const Polygon& a, const Polygon& b, const std::vector<Polygon>& blockers) {
    Bounds3 box;
    for (const Vec3& v : a.vertices) box.extend(v);
    for (const Vec3& v : b.vertices) box.extend(v);
    for (const Polygon& p : blockers)
        for (const Vec3& v : p.vertices) box.extend(v);
    return 1e-11 * box.diagonal().norm();
}

}  // namespace

double point_to_polygon_obstructed(const Vec3& x, const Vec3& n, const Polygon& receiver,
                                   const std::vector<Polygon>& blockers) {
    const detail::BlockerSet set = make_blockers(blockers);
    std::vector<int> all(set.size());
    std::iota(all.begin(), all.end(), 0);
    const double eps = pair_eps(receiver, receiver, blockers);
    double total = 0.0;
    for (const Polygon& r : detail::BlockerSet::convex_parts(receiver)) {
        double unobs = 0.0;
        const double hidden = detail::point_hidden(x, n, r, set, all.data(),
                                                   static_cast<int>(all.size()), eps, &unobs);
        total += std::max(0.0, unobs - hidden);
    }
    return total;
}

ObstructedFormFactor polygon_to_polygon_obstructed(const Polygon& a, const Polygon& b,
                                                   const std::vector<Polygon>& blockers,
                                                   double tolerance) {
    ObstructedFormFactor out;
    out.unobstructed = polygon_to_polygon(a, b);
    out.value = out.unobstructed;
    if (!(out.unobstructed > 0.0) || blockers.empty()) return out;
    const detail::BlockerSet set = make_blockers(blockers);
    const double eps = pair_eps(a, b, blockers);
    std::vector<int> all(set.size());
    std::iota(all.begin(), all.end(), 0);
    double hidden = 0.0;
    for (const Polygon& r : detail::BlockerSet::convex_parts(b)) {
        const detail::HiddenIntegral h = detail::hidden_integral(
            a, r, set, all.data(), static_cast<int>(all.size()), tolerance, eps);
        hidden += h.hidden;
        out.error_estimate += h.error;
        out.max_level = std::max(out.max_level, h.max_level);
        out.cells += h.cells;
    }
    out.value = std::clamp(out.unobstructed - hidden, 0.0, out.unobstructed);
    return out;
}

}  // namespace formfactor
