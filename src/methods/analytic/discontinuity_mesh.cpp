// The sender of a partly hidden pair cut into convex pieces along the lines where the integrand
// F(x → hidden part of r) has kinks (discontinuity meshing, Heckbert 1992; Lischinski et al.
// 1992), so that hidden_integral() integrates smooth pieces. See docs/analytic.md, "Obstructed
// scenes".

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"
#include "methods/analytic/vertex_shadow.h"

namespace formfactor::detail {

namespace {

// An event line a u + b v = c ((a, b) unit) in the sender's plane coordinates; when bounded,
// only its segment p0 p1 matters.
struct Line {
    double a, b, c;
    bool bounded;
    Vec2 p0, p1;
};

// Cyrus–Beck: the range [t0, t1] of t ∈ [0, 1] where p0 + t (p1 − p0) lies in the convex
// counter-clockwise polygon of the n vertices at(k), its edges moved inward by `inset`
// (outward when negative). False when that range is empty.
template <class At>
bool clip_segment(const Vec2& p0, const Vec2& p1, int n, At at, double inset, double& t0,
                  double& t1) {
    t0 = 0.0;
    t1 = 1.0;
    const Vec2 d = p1 - p0;
    double size = 0.0;
    for (int k = 1; k < n; ++k) size = std::max(size, (at(k) - at(0)).cwiseAbs().maxCoeff());
    const double min_edge = 1e-12 * size;
    for (int k = 0; k < n; ++k) {
        const Vec2 v0 = at(k);
        const Vec2 e = at(k + 1 == n ? 0 : k + 1) - v0;
        const double el = e.norm();
        // An edge of rounding's length (a cut through a vertex leaves two vertices 1e-16 of
        // the polygon's size apart) has no direction: its half-plane, at a random angle through
        // the vertex, would cut the polygon in two. Left out, the polygon grows by as little.
        if (!(el > min_edge)) continue;
        // Inside: cross(e, p − v0) ≥ inset·|e|.
        const double f0 = e.x() * (p0.y() - v0.y()) - e.y() * (p0.x() - v0.x()) - inset * el;
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
    return true;
}

}  // namespace

bool segment_crosses(const Vec2& p0, const Vec2& p1, const std::vector<Vec2>& q, double tol) {
    double t0, t1;
    const auto at = [&](int k) { return q[static_cast<std::size_t>(k)]; };
    return clip_segment(p0, p1, static_cast<int>(q.size()), at, tol, t0, t1) &&
           (t1 - t0) * (p1 - p0).norm() > tol;
}

namespace {

// True when the segment p0 p1 comes within tol of the convex counter-clockwise polygon q.
bool segment_near(const Vec2& p0, const Vec2& p1, const Poly2& q, double tol) {
    double t0, t1;
    const auto at = [&](int k) {
        return Vec2(q.x[static_cast<std::size_t>(k)], q.y[static_cast<std::size_t>(k)]);
    };
    return clip_segment(p0, p1, q.n, at, -tol, t0, t1);
}

// True when the line of l comes within tol of the convex polygon q.
bool line_near(const Line& l, const Poly2& q, double tol) {
    bool pos = false, neg = false;
    for (int k = 0; k < q.n; ++k) {
        const double d =
            l.a * q.x[static_cast<std::size_t>(k)] + l.b * q.y[static_cast<std::size_t>(k)] - l.c;
        pos = pos || d >= -tol;
        neg = neg || d <= tol;
    }
    return pos && neg;
}

}  // namespace

// The sender cut into convex pieces along the lines where F(x → hidden part of r) has kinks:
// the intersections of the sender's plane with the planes through a vertex of one polygon and
// an edge of another, among r and the candidate pieces (each clipped to the slab between the
// sender's and the receiver's planes). Across such a line a shadow vertex crosses an edge of the
// receiver or of another shadow (discontinuity meshing, Heckbert 1992; Lischinski et al. 1992);
// inside a piece the integrand is smooth but for the weaker edge-edge-edge events.
// Two faces of a convex solid whose normals are within this angle's cosine (30°) meet along a
// smooth edge: a finely faceted curved surface (a sphere of 22 bands: 16°). A vertex whose two
// edges in a face are both smooth turns the shadow's boundary by little, and the events it makes
// are weak (see split_by_events()).
constexpr double kSmoothEdgeCos = 0.8660254037844386;

std::vector<Polygon> split_by_events(const Polygon& s, const Vec3& ns, const Receiver& rc,
                                     const BlockerSet& blockers, const int* cand, int n, double eps,
                                     std::size_t max_pieces, bool* budget_spent) {
    if (budget_spent) *budget_spent = false;
    std::vector<Polygon> convex_s = BlockerSet::convex_parts(s);
    const double ds = ns.dot(s[0]);
    // The polygons whose vertices and edges make events.
    thread_local std::vector<Poly3> polys;
    // Per polygon: a bit per edge that cannot be a kink (an edge between two faces of a closed
    // solid that both cover their shadows, below: inside the union of the shadows).
    thread_local std::vector<std::uint64_t> inner;
    thread_local std::vector<Plane> plane_of;  // per polygon: its plane
    // Per polygon: its convex solid when every point of the sender is outside it (culls it),
    // else −1. Seen from such a point the solid's shadow is convex, the projection of its
    // silhouette: a vertex and an edge of two faces of that solid make a kink only when the
    // vertex lies in the edge's face plane (the silhouette gains or loses that face); any other
    // crossing of the two happens inside the shadow or would break its convexity.
    thread_local std::vector<int> solid_of;
    // Per polygon: a bit per edge that is smooth (kSmoothEdgeCos) in its closed solid, for the
    // polygon as the piece is (not clipped).
    thread_local std::vector<std::uint64_t> smooth;
    polys.clear();
    inner.clear();
    smooth.clear();
    plane_of.clear();
    solid_of.clear();
    Poly3 a, b;
    clip3(rc.poly, ns, ds + eps, a);
    const bool have_receiver = a.n >= 3;
    if (have_receiver) {
        polys.push_back(a);
        inner.push_back(0);
        smooth.push_back(0);
        plane_of.push_back(Plane{rc.n, rc.d});
        solid_of.push_back(-1);
    }
    const Vec3* sv_ = s.vertices.data();
    const int sn_ = static_cast<int>(s.size());
    // Culling of a piece's solid holds for the whole sender (pieces of closed solids apart
    // from other geometry, or of convex solids the sender is outside of).
    // One answer per solid for this sender (culls_all() loops over the solid's faces).
    thread_local std::vector<signed char> solid_culls;
    solid_culls.assign(static_cast<std::size_t>(blockers.solid_count()), 0);
    auto culls_sender = [&](int k) {
        const auto& pc = blockers.piece(k);
        if (pc.cull_back || pc.solid < 0) return blockers.culls_polygon(k, sv_, sn_);
        signed char& st = solid_culls[static_cast<std::size_t>(pc.solid)];
        if (st == 0) st = blockers.culls_polygon(k, sv_, sn_) ? 1 : 2;
        return st == 1;
    };
    auto faces_sender = [&](int k) {
        const auto& pc = blockers.piece(k);
        if (!culls_sender(k)) return false;
        for (const Vec3& v : s.vertices)
            if (!(pc.plane.signed_distance(v) > 0.0)) return false;
        return true;
    };
    // The pieces of this pair that cover their own shadow's part of the union: faces of a
    // closed solid, whole (neither plane cuts them), strictly between the sender's plane and
    // the receiver's (a piece in the receiver's plane casts no shadow: point_kernel.cpp) and
    // facing the whole sender. An edge between two of them is inner; across an edge to a face
    // that is not one of them (clipped away behind the receiver's plane, or not a candidate: its
    // shadow misses the receiver) the edge's shadow can bound the hidden part, and its events
    // are kept. Not for a solid open along a loop (a building on the ground): with its inner
    // edges left out, a pair of walls across a street of such buildings (the urban array's, the
    // ground apart) was integrated 7.6e-7 too low at --tolerance 1e-9, by rules that agreed.
    thread_local std::vector<std::uint32_t> cover_stamp;
    thread_local std::uint32_t cover_epoch = 0;
    if (cover_stamp.size() < blockers.size()) cover_stamp.assign(blockers.size(), 0);
    if (++cover_epoch == 0) {
        std::fill(cover_stamp.begin(), cover_stamp.end(), 0);
        cover_epoch = 1;
    }
    thread_local std::vector<int> poly_piece;  // per polygon: its piece when it covers, else −1
    poly_piece.clear();
    if (have_receiver) poly_piece.push_back(-1);
    for (int c = 0; c < n; ++c) {
        const auto& pc = blockers.piece(cand[c]);
        const Vec3* pv = blockers.vertices(cand[c]);
        if (culls_sender(cand[c])) {
            bool front = false;
            for (const Vec3& v : s.vertices) front = front || pc.plane.signed_distance(v) > 0.0;
            if (!front) continue;
        }
        a.n = pc.count;
        for (int k = 0; k < pc.count; ++k) a.v[static_cast<std::size_t>(k)] = pv[k];
        clip3(a, ns, ds, b);
        clip3(b, rc.n, rc.d, a);
        if (a.n < 3) continue;
        std::uint64_t smooth_mask = 0;
        bool whole = a.n == pc.count && pc.count <= 64;
        for (int k = 0; k < pc.count && whole; ++k)
            whole = a.v[static_cast<std::size_t>(k)] == pv[k];
        bool covers = false;
        if (whole) {
            covers = (pc.solid < 0 || !blockers.solid_open(pc.solid)) && faces_sender(cand[c]);
            for (int k = 0; k < pc.count && covers; ++k)
                covers = rc.n.dot(pv[k]) - rc.d > eps && ns.dot(pv[k]) - ds > 0.0;
            for (int k = 0; k < pc.count; ++k) {
                const int nb = blockers.neighbor(cand[c], k);
                if (nb < 0) continue;
                if (pc.plane.n.dot(blockers.piece(nb).plane.n) >= kSmoothEdgeCos)
                    smooth_mask |= std::uint64_t{1} << k;
            }
        }
        if (covers) cover_stamp[static_cast<std::size_t>(cand[c])] = cover_epoch;
        poly_piece.push_back(covers ? cand[c] : -1);
        polys.push_back(a);
        inner.push_back(0);  // set below, once every covering piece is known
        smooth.push_back(smooth_mask);
        plane_of.push_back(pc.plane);
        solid_of.push_back(pc.solid >= 0 && culls_sender(cand[c]) ? pc.solid : -1);
    }
    for (std::size_t x = 0; x < polys.size(); ++x) {
        const int k = poly_piece[x];
        if (k < 0) continue;
        std::uint64_t mask = 0;
        for (int e = 0; e < blockers.piece(k).count; ++e) {
            const int nb = blockers.neighbor(k, e);
            if (nb >= 0 && cover_stamp[static_cast<std::size_t>(nb)] == cover_epoch)
                mask |= std::uint64_t{1} << e;
        }
        inner[x] = mask;
    }
    if (polys.size() < 2) return convex_s;
    Vec3 su, sv;
    orthonormal_basis(ns, su, sv);
    const Vec3 o = s[0];
    const double tol = 1e-9 * diameter(s);

    thread_local std::vector<Line> lines;
    lines.clear();
    // The same event line found again (several vertex-edge pairs on one plane; in jittered
    // models vertices that nearly coincide make bundles of them) cuts nothing new: the segments
    // are merged into the line already there, which keeps the cut's piece budget for lines
    // that matter.
    auto add_event = [&](const Line& l) {
        for (Line& m : lines) {
            if (std::abs(l.a * m.b - l.b * m.a) > 1e-9) continue;
            const double sgn = l.a * m.a + l.b * m.b > 0.0 ? 1.0 : -1.0;
            if (std::abs(l.c - sgn * m.c) > tol) continue;
            if (!m.bounded) return;
            if (!l.bounded) {
                m.bounded = false;
                return;
            }
            // Both bounded: m's segment stretched over l's along the common direction.
            const Vec2 t(m.b, -m.a);
            double lo = std::min(t.dot(m.p0), t.dot(m.p1)), hi = std::max(t.dot(m.p0), t.dot(m.p1));
            lo = std::min({lo, t.dot(l.p0), t.dot(l.p1)});
            hi = std::max({hi, t.dot(l.p0), t.dot(l.p1)});
            const Vec2 base = m.c * Vec2(m.a, m.b);
            m.p0 = base + lo * t;
            m.p1 = base + hi * t;
            return;
        }
        lines.push_back(l);
    };
    thread_local std::vector<Vec2> s2;
    s2.clear();
    for (const Vec3& v : s.vertices) s2.emplace_back(su.dot(v - o), sv.dot(v - o));
    Poly2 s2p;  // the sender, counter-clockwise, for clipping
    s2p.n = static_cast<int>(std::min<std::size_t>(s2.size(), kCap));
    for (int k = 0; k < s2p.n; ++k) {
        s2p.x[static_cast<std::size_t>(k)] = s2[static_cast<std::size_t>(k)].x();
        s2p.y[static_cast<std::size_t>(k)] = s2[static_cast<std::size_t>(k)].y();
    }
    if (area2(s2p) < 0.0) {
        std::reverse(s2p.x.begin(), s2p.x.begin() + s2p.n);
        std::reverse(s2p.y.begin(), s2p.y.begin() + s2p.n);
    }
    Bounds3 pair_box;
    for (const Vec3& v : s.vertices) pair_box.extend(v);
    for (int k = 0; k < rc.poly.n; ++k) pair_box.extend(rc.poly.v[static_cast<std::size_t>(k)]);
    const double tol_r = 1e-9 * pair_box.diagonal().norm();
    const double tol_coplanar = 1e-4 * pair_box.diagonal().norm();
    const bool sender_convex = s.size() <= static_cast<std::size_t>(kCap) && is_convex(s);
    Poly2 seen;  // where in the sender a blocker vertex's shadow falls on the receiver
    for (std::size_t x = 0; x < polys.size(); ++x)
        for (int w = 0; w < polys[x].n; ++w) {
            // A vertex between two inner edges is inside the union too.
            const int wprev = w == 0 ? polys[x].n - 1 : w - 1;
            const int wnext = w + 1 == polys[x].n ? 0 : w + 1;
            if ((inner[x] >> w & 1) && (inner[x] >> wprev & 1)) continue;
            // A smooth vertex (both its edges here smooth, a finely faceted curved solid): where
            // its shadow crosses an edge's, the shadow's boundary turns there by at most the
            // solid's small dihedral angles, so F(x → hidden part of r) changes its second
            // derivative by little (a weak event; Heckbert 1992), and the rules' estimates in
            // the cells around it hold. Cutting along every such event cut a faceted sphere's
            // pairs into ~230 pieces each; a corner crossing the smooth shadow boundary (a
            // vertex of the receiver or of a sharp blocker) still cuts.
            if ((smooth[x] >> w & 1) && (smooth[x] >> wprev & 1)) continue;
            const Vec3& pw = polys[x].v[static_cast<std::size_t>(w)];
            // w on the sender's plane (or behind it): no kink in front, whatever the edge.
            const double hw = ns.dot(pw) - ds;
            if (!(hw > 0.0)) continue;
            // The sender's vertices seen from w: an event plane through w has them all on one
            // side (closed) unless its line crosses the sender.
            // (A sender of more than kCap vertices goes without it.)
            const bool sign_test = s.size() <= static_cast<std::size_t>(kCap);
            std::array<Vec3, kCap> from_w;
            for (std::size_t k = 0; sign_test && k < s.size(); ++k) from_w[k] = s[k] - pw;
            // The event of a blocker vertex w and an edge e happens where, seen from x, w's
            // shadow crosses e's shadow (or e, when e is the receiver's): the crossing point is
            // w's shadow, so F(x → hidden part of r) has a kink there only if w's shadow falls
            // on the receiver. The sender points x whose line through w meets the receiver
            // beyond w are the receiver's part above w (farther from the sender's plane)
            // projected centrally through w onto the sender's plane, a convex polygon; cut to
            // the (convex) sender it bounds every such event of w. Not for vertices in the
            // receiver's plane: their shadow is the vertex itself, so they make kinks only when
            // they lie on the receiver (within tol).
            const bool blocker_vertex = have_receiver && x != 0;
            const bool on_plane = blocker_vertex && !(rc.n.dot(pw) - rc.d > tol_r);
            const bool filter = blocker_vertex && (on_plane || sender_convex);
            const bool seen_some =
                filter && (on_plane ? on_polygon(polys[0], rc.n, pw, tol_r)
                                    : shadow_region(polys[0], pw, ns, ds, su, sv, o, s2p, seen));
            const bool filter_off = on_plane && seen_some;  // on r: every event is kept
            for (std::size_t y = 0; y < polys.size(); ++y) {
                if (y == x) continue;
                const Poly3& q = polys[y];
                // A vertex in q's plane (a vertex of a face adjacent to q, or of q's own plane)
                // makes the face-plane event: x in q's plane sees q edge-on, and q's shadow
                // leaves or joins the union along the whole projected face, wherever the
                // vertex's shadow falls. Those events are kept.
                // Nearly coplanar (jittered models) counts as coplanar.
                const bool only_seen = filter && !filter_off &&
                                       std::abs(plane_of[y].signed_distance(pw)) > tol_coplanar;
                // A vertex in r's plane off r, or a vertex whose shadow falls nowhere on r:
                // only its events along an edge of its own (below) can make a kink.
                const bool edges_only = only_seen && (on_plane || !seen_some);
                if (solid_of[x] >= 0 && solid_of[x] == solid_of[y] &&
                    std::abs(plane_of[y].signed_distance(pw)) > tol_coplanar)
                    continue;  // two faces of one convex solid, no face-plane event
                for (int e = 0; e < q.n; ++e) {
                    if (inner[y] >> e & 1) continue;
                    const Vec3& e0 = q.v[static_cast<std::size_t>(e)];
                    const Vec3& e1 = q.v[static_cast<std::size_t>(e + 1 == q.n ? 0 : e + 1)];
                    const Vec3 m = (e1 - e0).cross(pw - e0);
                    // Most event lines miss the sender (on the urban array 7 x 7, 3 in 4): the
                    // sign of m · (vertex − w) rejects them before the line's normalisation. The
                    // test below asks for vertices more than tol from the line on either side,
                    // so it rejects every line this one does.
                    if (sign_test) {
                        bool above = false, below = false;
                        for (std::size_t k = 0; k < s.size(); ++k) {
                            const double sd = m.dot(from_w[k]);
                            above = above || sd > 0.0;
                            below = below || sd < 0.0;
                        }
                        if (!(above && below)) continue;
                    }
                    const double la = m.dot(su), lb = m.dot(sv);
                    const double len = std::sqrt(la * la + lb * lb);
                    if (!(len > 1e-12 * m.norm()) || !(len > 0.0)) continue;
                    // The line must cross the sender (the cheapest test first).
                    Line l{la / len, lb / len, m.dot(e0 - o) / len, true, {}, {}};
                    bool pos = false, neg = false;
                    for (const Vec2& p : s2) {
                        const double d = l.a * p.x() + l.b * p.y() - l.c;
                        pos = pos || d > tol;
                        neg = neg || d < -tol;
                    }
                    if (!(pos && neg)) continue;
                    // An edge of w's polygon at w in the event's plane (parallel to e, as the
                    // vertical edges of walls and of a wall receiver are): its shadow and e's
                    // (or e) lie on one line at the event, and they overlap along a segment, not
                    // at w's shadow; where that segment crosses r, the hidden part's area has a
                    // kink of the first derivative even when w's shadow, and the other end's,
                    // fall off r. The shadow filter does not hold for it.
                    // Nearly parallel (jittered models) counts as parallel. Only if the event's
                    // plane meets r, where that segment lies.
                    const bool along_edge =
                        only_seen &&
                        (in_plane(m, pw, polys[x].v[static_cast<std::size_t>(wnext)],
                                  tol_coplanar) ||
                         in_plane(m, pw, polys[x].v[static_cast<std::size_t>(wprev)],
                                  tol_coplanar)) &&
                        plane_meets(m, pw, polys[0], tol_r);
                    if (edges_only && !along_edge) continue;
                    const bool filtered = only_seen && !along_edge;
                    // The event happens only on the projection of the edge through the vertex
                    // onto the sender's plane: x, w and a point of e collinear.
                    const double h0 = ns.dot(e0) - ds, h1 = ns.dot(e1) - ds;
                    const double d0 = hw - h0, d1 = hw - h1;
                    if ((d0 > 0.0 && d1 > 0.0) || (d0 < 0.0 && d1 < 0.0)) {
                        const Vec3 x0 = pw + (e0 - pw) * (hw / d0) - o;
                        const Vec3 x1 = pw + (e1 - pw) * (hw / d1) - o;
                        l.bounded = true;
                        l.p0 = Vec2(su.dot(x0), sv.dot(x0));
                        l.p1 = Vec2(su.dot(x1), sv.dot(x1));
                        if (!segment_crosses(l.p0, l.p1, s2, tol)) continue;
                        if (filtered && !(seen_some && segment_near(l.p0, l.p1, seen, tol)))
                            continue;
                    } else {
                        l.bounded = false;
                        if (filtered && !(seen_some && line_near(l, seen, tol))) continue;
                    }
                    add_event(l);
                }
            }
        }
    // Near contact (jittered models: a box resting on a wall with a gap of 1e-5, walls whose
    // edges nearly meet): an edge hovering a small height h > 0 above the sender's plane, over
    // or next to the sender, makes F(x → hidden part of r) change over distances ~h from the
    // edge's projection, where Gauss points a cell's size away see only the tail. The sender is
    // cut along lines parallel to that projection at offsets growing geometrically (×4) from h to
    // the sender's size (a graded mesh toward the near-singular line), so that each piece is
    // smooth at its own scale and the rules' error estimates hold. Edges in the sender's plane
    // (touching, crossing) are clipped exactly and need nothing.
    // "Small" against the sender's width (area / diameter), not its length: a thin sender
    // (the side of a plate) has nothing to grade across it beyond its width.
    const double diam_s = diameter(s);
    const double contact_max = 1e-2 * std::min(diam_s, area(s) / diam_s);
    // Heights up to a few eps are touching (the receiver is clipped at eps in front).
    const double touch = std::max(tol, 4.0 * eps);
    // A line (unit normal nn, offset c) bounded to the projection p0 p1 stretched by `ext`,
    // unless a parallel line within `merge` is there already.
    auto add_line = [&](const Vec2& nn, double c, const Vec2& p0, const Vec2& p1, double ext,
                        double merge) {
        const Vec2 t(nn.y(), -nn.x());
        Line l{nn.x(), nn.y(), c, true, {}, {}};
        l.p0 = p0 - ext * t + (c - nn.dot(p0)) * nn;
        l.p1 = p1 + ext * t + (c - nn.dot(p1)) * nn;
        if ((l.p1 - l.p0).dot(t) < 0.0) std::swap(l.p0, l.p1);
        if (!segment_crosses(l.p0, l.p1, s2, tol)) return;
        for (const Line& m : lines) {
            if (std::abs(l.a * m.b - l.b * m.a) > 1e-3) continue;
            const double dot = l.a * m.a + l.b * m.b;
            if (std::abs(l.c - (dot > 0.0 ? m.c : -m.c)) <= merge) return;
        }
        lines.push_back(l);
    };
    bool graded = false;
    for (std::size_t x = 0; x < polys.size(); ++x) {
        const Poly3& q = polys[x];
        double hq = 0.0;  // how far q reaches in front of the sender's plane
        for (int e = 0; e < q.n; ++e)
            hq = std::max(hq, ns.dot(q.v[static_cast<std::size_t>(e)]) - ds);
        if (!(hq > touch)) continue;  // in the plane: hides nothing
        for (int e = 0; e < q.n; ++e) {
            const Vec3& e0 = q.v[static_cast<std::size_t>(e)];
            const Vec3& e1 = q.v[static_cast<std::size_t>(e + 1 == q.n ? 0 : e + 1)];
            double h = std::max(ns.dot(e0) - ds, ns.dot(e1) - ds);
            const Vec2 p0(su.dot(e0 - o), sv.dot(e0 - o)), p1(su.dot(e1 - o), sv.dot(e1 - o));
            const double len = (p1 - p0).norm();
            if (!(len > tol)) continue;
            const Vec2 t = (p1 - p0) / len, nn(-t.y(), t.x());
            const double c0 = nn.dot(p0);
            if (!(h > touch)) {
                // An edge in the sender's plane: where q crosses it (a blocker through the
                // sender) F(x → hidden part) jumps; graded by how far q reaches in front.
                add_line(nn, c0, p0, p1, 0.0, 0.0);
                h = hq;
            }
            if (h > contact_max) continue;
            graded = true;
            for (double off = h; off < 0.5 * diam_s; off *= 4.0)
                for (double sign : {-1.0, 1.0})
                    // A mesh graded by 4 needs no second line within a quarter of the offset
                    // of one already there (parallel edges of one sliver, a vertex's events).
                    add_line(nn, c0 + sign * off, p0, p1, off, 0.25 * off);
        }
    }
    if (lines.empty()) return convex_s;
    // Cut (in the sender's plane coordinates).
    thread_local std::vector<Poly2> cur, nxt;
    cur.clear();
    for (const Polygon& p : convex_s) {
        Poly2 q;
        q.n = static_cast<int>(p.size());
        for (std::size_t k = 0; k < p.size(); ++k) {
            q.x[k] = su.dot(p[k] - o);
            q.y[k] = sv.dot(p[k] - o);
        }
        append2(cur, q);
    }
    // At most 1,024 pieces; a mesh graded towards near contact needs more (its parallels cut
    // each other near the sender's corners and the events' lines): 4,096. The lines left once
    // the budget is spent are not cut, and the rules can agree across their kinks: with 256, a
    // pair of walls across the urban array 7 x 7 (hundreds of buildings between) was integrated
    // 1.0e-6 too low at --tolerance 1e-8.
    const std::size_t kMaxPieces = graded ? 4096 : 1024;
    thread_local std::vector<Vec2> scratch2;
    for (const Line& l : lines) {
        nxt.clear();
        for (std::size_t at = 0; at < cur.size(); ++at) {
            const Poly2& q = cur[at];
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
                hit = segment_crosses(l.p0, l.p1, qv, tol);
            }
            // The pieces so far: those this line has passed and those it has yet to reach.
            if (hit && nxt.size() + (cur.size() - at) >= kMaxPieces) {
                if (budget_spent) *budget_spent = true;
                hit = false;
            }
            if (!hit) {
                append2(nxt, q);
                continue;
            }
            // A point on the line and its direction (b, −a).
            const double px = l.a * l.c, py = l.b * l.c;
            Poly2 left, right;
            split2(q, px, py, l.b, -l.a, left, right);
            if (left.n >= 3) append2(nxt, left);
            if (right.n >= 3) append2(nxt, right);
        }
        std::swap(cur, nxt);
        if (cur.size() >= max_pieces) return {};
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
