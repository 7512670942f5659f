// Obstructed form factors: the point kernel (F from a point to the part of a receiver the
// blocker pieces hide, by exact shadow polygons) and the adaptive integration of the hidden
// part of partly hidden pairs over the sender (Walton's adaptive method, NISTIR 6925), with the
// public functions of formfactor/methods/obstructed.h. The blocker set, the shaft tests, the
// shadow clipping and the sender's event split live beside it (blocker_set.cpp, shaft.cpp,
// shadow_clip.h, discontinuity_mesh.cpp). See docs/analytic.md, "Obstructed scenes".

#include "formfactor/methods/obstructed.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <queue>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"
#include "methods/analytic/obstructed_internal.h"
#include "methods/analytic/shadow_clip.h"

namespace formfactor {
namespace detail {

namespace {

// Up to this many shadows at a point, the hidden part is Lambert's formula over their union;
// above it, F(x → r) less Lambert's formula over what remains visible (see evaluate_point()).
constexpr std::size_t kUnionShadows = 3;

struct PointResult {
    double hidden = 0.0;
    double unobstructed = 0.0;  // F(x → r), when asked for
    bool all_hidden = false;    // x sees nothing of r (rounding slivers apart)
};

// A vertex of a front face of a convex solid, projected from x onto the receiver's plane
// unclipped (see evaluate_point()).
struct SolidPoint {
    int solid;
    double x, y;
};

// The part of the convex polygon `in` (counter-clockwise) on the left of the directed line
// a → b (Sutherland–Hodgman on a vector: a solid's silhouette may exceed kCap vertices).
// Returns false, leaving `out` as it was, when all of `in` is on the left already.
template <class P>
bool clip_left(const std::vector<P>& in, double ax, double ay, double bx, double by,
               std::vector<P>& out) {
    const std::size_t n = in.size();
    const double ex = bx - ax, ey = by - ay;
    bool all_inside = true;
    for (std::size_t k = 0; k < n && all_inside; ++k)
        all_inside = ex * (in[k].y - ay) - ey * (in[k].x - ax) >= 0.0;
    if (all_inside) return false;
    out.clear();
    for (std::size_t k = 0; k < n; ++k) {
        const P& p = in[k];
        const P& q = in[k + 1 == n ? 0 : k + 1];
        const double sp = ex * (p.y - ay) - ey * (p.x - ax);
        const double sq = ex * (q.y - ay) - ey * (q.x - ax);
        if (sp >= 0.0) out.push_back(p);
        if ((sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0)) {
            const double t = sp / (sp - sq);
            P r = p;
            r.x = p.x + t * (q.x - p.x);
            r.y = p.y + t * (q.y - p.y);
            out.push_back(r);
        }
    }
    return true;
}

// The shadows that the front faces of one convex solid cast from x (solid_of[k] ≥ 0, the same
// for all) are disjoint and their union is convex: the central projection of the solid's part
// inside the pyramid from x over the receiver (a segment from x that meets the solid enters it
// through a front face). Each such group becomes its convex hull: the union below then subtracts
// one polygon per solid rather than one per face, and Lambert's formula runs over the silhouette
// rather than over every face's edges (the inner edges of the faces cancel in the sum).
//
// `raw` holds, per solid, the unclipped projections of front faces that lie wholly between the
// receiver's plane and x's height above it (evaluate_point() skips their clipping): the
// projection from x is a projective map on that slab, so the hull of those points and of the
// clipped shadows of the solid's other front faces is the projection of a convex part of the
// solid that contains every entry point; cut by the receiver's polygon `whole`, it is exactly
// the union of the clipped shadows.
//
// A hull with more than kCap vertices (a finely faceted sphere's silhouette) is cut into a fan
// of convex polygons of at most kCap vertices, disjoint like the faces, so they keep the solid's
// index. Each group is gathered once (sorted by solid): O(n log n) in the shadows.
void merge_solid_shadows(std::vector<Poly2>& shadows, std::vector<int>& solid_of,
                         std::vector<SolidPoint>& raw, const Poly2& whole) {
    const std::size_t n = shadows.size();
    thread_local std::vector<std::pair<int, int>> by_solid;  // (solid, shadow), sorted
    by_solid.clear();
    for (std::size_t k = 0; k < n; ++k)
        if (solid_of[k] >= 0) by_solid.emplace_back(solid_of[k], static_cast<int>(k));
    if (raw.empty()) {
        if (by_solid.size() < 2) return;
        std::sort(by_solid.begin(), by_solid.end());
        bool repeated = false;
        for (std::size_t g = 1; g < by_solid.size() && !repeated; ++g)
            repeated = by_solid[g].first == by_solid[g - 1].first;
        if (!repeated) return;
    } else {
        std::sort(by_solid.begin(), by_solid.end());
        std::sort(raw.begin(), raw.end(),
                  [](const SolidPoint& p, const SolidPoint& q) { return p.solid < q.solid; });
    }
    struct P {
        double x, y;
    };
    thread_local std::vector<P> pts, hull, clipped;
    thread_local std::vector<Poly2> out;
    thread_local std::vector<int> out_solid;
    out.clear();
    out_solid.clear();
    const bool whole_ccw = area2(whole) > 0.0;
    double extent = 0.0;
    for (int k = 0; k < whole.n; ++k)
        extent = std::max({extent, std::abs(whole.x[static_cast<std::size_t>(k)] - whole.x[0]),
                           std::abs(whole.y[static_cast<std::size_t>(k)] - whole.y[0])});
    const double merge_tol = 1e-12 * extent;
    // One solid's points (its clipped shadows by_solid[s, e) and its raw points) as its hull,
    // cut by `whole` when raw points are among them, fanned into polygons of ≤ kCap vertices.
    auto emit = [&](int so, std::size_t s, std::size_t e) {
        pts.clear();
        for (std::size_t m = s; m < e; ++m) {
            const Poly2& q = shadows[static_cast<std::size_t>(by_solid[m].second)];
            for (int v = 0; v < q.n; ++v)
                pts.push_back({q.x[static_cast<std::size_t>(v)], q.y[static_cast<std::size_t>(v)]});
        }
        const auto rr = std::equal_range(
            raw.begin(), raw.end(), SolidPoint{so, 0.0, 0.0},
            [](const SolidPoint& p, const SolidPoint& q) { return p.solid < q.solid; });
        const bool has_raw = rr.first != rr.second;
        for (auto it = rr.first; it != rr.second; ++it) pts.push_back({it->x, it->y});
        if (!has_raw && e - s == 1) {
            out.push_back(shadows[static_cast<std::size_t>(by_solid[s].second)]);
            out_solid.push_back(so);
            return;
        }
        convex_hull_2d(pts, hull);
        if (has_raw) {
            for (int k = 0; k < whole.n && hull.size() >= 3; ++k) {
                const int a = whole_ccw ? k : whole.n - 1 - k;
                const int b = whole_ccw ? (k + 1) % whole.n : (a + whole.n - 1) % whole.n;
                if (clip_left(hull, whole.x[static_cast<std::size_t>(a)],
                              whole.y[static_cast<std::size_t>(a)],
                              whole.x[static_cast<std::size_t>(b)],
                              whole.y[static_cast<std::size_t>(b)], clipped))
                    hull.swap(clipped);
            }
        }
        // Vertices within 1e-12 of the receiver's size of the one before are dropped: the same
        // corner reached by two roundings (a raw projection and a clipped shadow) would make an
        // edge of no length whose direction is noise, and subtract() would cut along it.
        std::size_t kept = 0;
        for (std::size_t m = 0; m < hull.size(); ++m) {
            if (kept > 0 && std::abs(hull[m].x - hull[kept - 1].x) <= merge_tol &&
                std::abs(hull[m].y - hull[kept - 1].y) <= merge_tol)
                continue;
            hull[kept++] = hull[m];
        }
        while (kept >= 2 && std::abs(hull[kept - 1].x - hull[0].x) <= merge_tol &&
               std::abs(hull[kept - 1].y - hull[0].y) <= merge_tol)
            --kept;
        hull.resize(kept);
        const std::size_t hn = hull.size();
        if (hn < 3) {
            if (has_raw) return;  // nothing of the solid in front of the receiver
            // A hull that rounding made degenerate: the faces as they are.
            for (std::size_t m = s; m < e; ++m) {
                out.push_back(shadows[static_cast<std::size_t>(by_solid[m].second)]);
                out_solid.push_back(so);
            }
            return;
        }
        // Fan from hull[0]: polygons 0, a, a + 1, …, b with b − a + 2 ≤ kCap vertices.
        for (std::size_t a = 1; a + 1 < hn;) {
            const std::size_t b = std::min(hn - 1, a + static_cast<std::size_t>(kCap) - 2);
            out.emplace_back();
            Poly2& q = out.back();
            q.n = static_cast<int>(b - a + 2);
            q.x[0] = hull[0].x;
            q.y[0] = hull[0].y;
            for (std::size_t m = a; m <= b; ++m) {
                q.x[m - a + 1] = hull[m].x;
                q.y[m - a + 1] = hull[m].y;
            }
            out_solid.push_back(so);
            a = b;
        }
    };
    // Shadows outside any solid keep their place, and each group takes the place of its first
    // member (the smallest index: by_solid is sorted by index within a solid); solids with raw
    // points only come last.
    thread_local std::vector<int> group_at;  // per shadow: its group's start in by_solid, or −1
    group_at.assign(n, -1);
    for (std::size_t s = 0; s < by_solid.size();) {
        std::size_t e = s + 1;
        while (e < by_solid.size() && by_solid[e].first == by_solid[s].first) ++e;
        group_at[static_cast<std::size_t>(by_solid[s].second)] = static_cast<int>(s);
        for (std::size_t m = s + 1; m < e; ++m)
            group_at[static_cast<std::size_t>(by_solid[m].second)] = -2;  // a later member
        s = e;
    }
    for (std::size_t k = 0; k < n; ++k) {
        const int at = group_at[k];
        if (at == -2) continue;
        if (at == -1) {
            out.push_back(shadows[k]);
            out_solid.push_back(solid_of[k]);
            continue;
        }
        const auto s = static_cast<std::size_t>(at);
        std::size_t e = s + 1;
        while (e < by_solid.size() && by_solid[e].first == by_solid[s].first) ++e;
        emit(by_solid[s].first, s, e);
    }
    for (std::size_t r = 0; r < raw.size();) {
        const int so = raw[r].solid;
        std::size_t q = r;
        while (q < raw.size() && raw[q].solid == so) ++q;
        const bool with_shadows =
            std::binary_search(by_solid.begin(), by_solid.end(), std::make_pair(so, -1),
                               [](const std::pair<int, int>& a, const std::pair<int, int>& b) {
                                   return a.first < b.first;
                               });
        if (!with_shadows) emit(so, 0, 0);
        r = q;
    }
    shadows.swap(out);
    solid_of.swap(out_solid);
}

// The shadows that the candidate pieces cast from x (at height h above the receiver's plane) on
// rp, the receiver's part in front of x (`whole` in the receiver's plane coordinates): convex
// polygons in those coordinates, each a convex solid's whole shadow when x culls its back faces
// (merge_solid_shadows()), else one piece's. solid_of[k]: the solid of shadows[k], or −2 − the
// piece's index for a piece's own.
void cast_shadows(const Receiver& rc, const Vec3& x, double h, const Poly3& rp, const Poly2& whole,
                  const BlockerSet& blockers, const int* cand, int count, double eps,
                  std::vector<Poly2>& shadows, std::vector<int>& solid_of) {
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
    thread_local std::vector<SolidPoint> raw;
    // The front faces projected unclipped, and per piece the evaluation that marked it so.
    thread_local std::vector<int> raw_faces;
    thread_local std::vector<std::uint64_t> raw_mark;
    thread_local std::uint64_t raw_epoch = 0;
    if (raw_mark.size() < blockers.size()) raw_mark.assign(blockers.size(), 0);
    ++raw_epoch;
    shadows.clear();
    solid_of.clear();
    raw.clear();
    raw_faces.clear();
    // Per convex solid, whether x culls it (0 unknown, 1 yes, 2 no): one answer per point.
    thread_local std::vector<signed char> culls;
    thread_local std::vector<int> culls_set;
    culls.resize(static_cast<std::size_t>(blockers.solid_count()), 0);
    for (int so : culls_set) culls[static_cast<std::size_t>(so)] = 0;
    culls_set.clear();
    Poly3 buf[2];
    for (int c = 0; c < count; ++c) {
        const int pk = cand[c];
        const auto& pc = blockers.piece(pk);
        bool culled_solid = false;
        if (pc.cull_back || pc.solid >= 0) {
            const double dist = pc.plane.signed_distance(x);
            if (pc.cull_back) {
                culled_solid = true;
            } else {
                signed char& st = culls[static_cast<std::size_t>(pc.solid)];
                if (st == 0) {
                    st = blockers.culls_at(pc.solid, x, dist) ? 1 : 2;
                    culls_set.push_back(pc.solid);
                }
                culled_solid = st == 1;
            }
            if (culled_solid && !(dist > 0.0)) continue;
        }
        const Vec3* pv = blockers.vertices(pk);
        if (culled_solid && pc.solid >= 0) {
            // A front face of a convex solid wholly between the receiver's plane (above eps) and
            // x's height (below 0.99 of it, so that the projection stays within 100× the
            // distance) is projected unclipped, after the loop, into the solid's hull, which is
            // cut by the receiver there (merge_solid_shadows()). Else it is clipped as below.
            bool in_slab = true;
            for (int k = 0; k < pc.count && in_slab; ++k) {
                const double hy = rc.n.dot(pv[k]) - rc.d;
                in_slab = hy > eps && h - hy > 0.01 * h;
            }
            if (in_slab) {
                // Wholly outside one side of the pyramid: it hides nothing of the receiver.
                bool outside = false;
                for (int sd = 0; sd < sides && !outside; ++sd) {
                    outside = true;
                    for (int k = 0; k < pc.count && outside; ++k)
                        outside = side[static_cast<std::size_t>(sd)].dot(pv[k]) <
                                  side_off[static_cast<std::size_t>(sd)];
                }
                if (outside) continue;
                raw_mark[static_cast<std::size_t>(pk)] = raw_epoch;
                raw_faces.push_back(pk);
                continue;
            }
        }
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
        solid_of.push_back(culled_solid ? pc.solid : -2 - pk);
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
            solid_of.pop_back();
            continue;
        }
        if (ar < 0.0) {
            std::reverse(q.x.begin(), q.x.begin() + q.n);
            std::reverse(q.y.begin(), q.y.begin() + q.n);
        }
    }
    // The unclipped faces' vertices, but for those inside the region they cover: a vertex whose
    // two edges in this face both border another such face of the solid. Around a vertex whose
    // faces are all projected unclipped, their projections (front faces of a convex solid seen
    // from outside) cover a neighbourhood of its projection, so it is no corner of the hull;
    // every other vertex lies on an edge towards a face that is not, and that edge's face keeps
    // it. (A neighbour unknown, −1, keeps the vertex.)
    for (const int pk : raw_faces) {
        const auto& pc = blockers.piece(pk);
        const Vec3* pv = blockers.vertices(pk);
        auto inner = [&](int e) {
            const int nb = blockers.neighbor(pk, e);
            return nb >= 0 && raw_mark[static_cast<std::size_t>(nb)] == raw_epoch;
        };
        bool inner_prev = inner(pc.count - 1);
        for (int k = 0; k < pc.count; ++k) {
            const bool inner_next = inner(k);
            if (!(inner_prev && inner_next)) {
                const Vec3& y = pv[k];
                const double den = h - (rc.n.dot(y) - rc.d);
                const Vec3 w = x + (h / den) * (y - x) - rc.o;
                raw.push_back({pc.solid, rc.u.dot(w), rc.v.dot(w)});
            }
            inner_prev = inner_next;
        }
    }
    merge_solid_shadows(shadows, solid_of, raw, whole);
}

// x's height h above the receiver's plane, the receiver's part rp in front of x's plane (normal
// nx) and that part in the receiver's plane coordinates; false when x sees none of it.
bool receiver_in_front(const Receiver& rc, const Vec3& x, const Vec3& nx, double& h, Poly3& rp,
                       Poly2& whole) {
    h = rc.n.dot(x) - rc.d;
    if (!(h > 0.0)) return false;
    clip3(rc.poly, nx, nx.dot(x), rp);
    if (rp.n < 3) return false;
    whole.n = rp.n;
    for (int k = 0; k < rp.n; ++k) {
        const Vec3 w = rp.v[static_cast<std::size_t>(k)] - rc.o;
        whole.x[static_cast<std::size_t>(k)] = rc.u.dot(w);
        whole.y[static_cast<std::size_t>(k)] = rc.v.dot(w);
    }
    return true;
}

// F(x → part of the receiver hidden by the candidate pieces); see point_hidden().
PointResult evaluate_point(const Receiver& rc, const Vec3& x, const Vec3& nx,
                           const BlockerSet& blockers, const int* cand, int count, double eps,
                           bool want_unobstructed) {
    PointResult res;
    double h = 0.0;
    Poly3 rp;
    Poly2 whole;
    if (!receiver_in_front(rc, x, nx, h, rp, whole)) return res;
    const Vec3 xr = x - rc.o;
    const Vec3 xl(rc.u.dot(xr), rc.v.dot(xr), h);
    const Vec3 nl(nx.dot(rc.u), nx.dot(rc.v), nx.dot(rc.n));
    if (want_unobstructed) {
        res.unobstructed = lambert2(whole, xl, nl);
    }
    if (count == 0) return res;
    // A convex solid that hides every segment from x to the receiver's part in front of x (the
    // segments to its vertices decide, BlockerSet::solid_hides()): all of it is hidden, and no
    // piece need be projected. Most points of a cell between buildings see nothing of the
    // receiver, each from behind some building, though no one building hides the whole cell.
    {
        int tried[4] = {-1, -1, -1, -1};
        for (int c = 0; c < count; ++c) {
            const int so = blockers.piece(cand[c]).solid;
            if (so < 0 || std::find(std::begin(tried), std::end(tried), so) != std::end(tried))
                continue;
            std::rotate(std::begin(tried), std::begin(tried) + 3, std::end(tried));
            tried[0] = so;
            if (blockers.solid_hides(so, &x, 1, rp.v.data(), rp.n)) {
                res.hidden = want_unobstructed ? res.unobstructed : lambert2(whole, xl, nl);
                res.all_hidden = true;
                return res;
            }
        }
    }
    thread_local std::vector<Poly2> shadows, frags, next;
    // Per shadow: the convex solid whose front faces cast it, when x culls that solid's back
    // faces (else −2 − the piece). The front faces of a convex solid seen from outside do not
    // overlap, so shadows of one such solid need not be subtracted from each other.
    thread_local std::vector<int> solid_of;
    cast_shadows(rc, x, h, rp, whole, blockers, cand, count, eps, shadows, solid_of);
    if (shadows.empty()) return res;
    // Fragments below 1e-14 of the receiver's size² are rounding slivers of the subtraction.
    const double tiny_area = 1e-14 * (rp.v[0] - rp.v[2]).squaredNorm();
    auto box_of = [](const Poly2& q) {
        std::array<double, 4> b = {q.x[0], q.y[0], q.x[0], q.y[0]};
        for (int m = 1; m < q.n; ++m) {
            b[0] = std::min(b[0], q.x[static_cast<std::size_t>(m)]);
            b[1] = std::min(b[1], q.y[static_cast<std::size_t>(m)]);
            b[2] = std::max(b[2], q.x[static_cast<std::size_t>(m)]);
            b[3] = std::max(b[3], q.y[static_cast<std::size_t>(m)]);
        }
        return b;
    };
    auto apart = [](const std::array<double, 4>& a, const std::array<double, 4>& b) {
        return a[0] > b[2] || a[2] < b[0] || a[1] > b[3] || a[3] < b[1];
    };
    thread_local std::vector<std::array<double, 4>> boxes;
    if (shadows.size() <= kUnionShadows) {
        // Few shadows: their union as disjoint convex fragments, shadow k minus shadows
        // 0..k−1 (a shadow whose box is apart from shadow k's takes nothing from it), and
        // Lambert's formula over those fragments.
        double covered = 0.0;  // the union's area
        boxes.resize(shadows.size());
        for (std::size_t k = 0; k < shadows.size(); ++k) boxes[k] = box_of(shadows[k]);
        for (std::size_t k = 0; k < shadows.size(); ++k) {
            frags.clear();
            frags.push_back(shadows[k]);
            for (std::size_t l = 0; l < k && !frags.empty(); ++l) {
                if (solid_of[k] >= 0 && solid_of[k] == solid_of[l]) continue;
                if (apart(boxes[l], boxes[k])) continue;
                next.clear();
                for (const Poly2& f : frags) subtract(f, shadows[l], next);
                std::swap(frags, next);
            }
            for (const Poly2& f : frags) {
                const double af = area2(f);
                if (af > tiny_area) {
                    res.hidden += lambert2(f, xl, nl);
                    covered += af;
                }
            }
        }
        res.all_hidden = covered >= (1.0 - 1e-9) * std::abs(area2(whole));
        return res;
    }
    // Many shadows: what x sees of the receiver, rp minus every shadow, as disjoint convex
    // fragments; the hidden part is F(x → rp) less F(x → those fragments). Subtracting from
    // what is still visible (rather than forming the union, each shadow minus all before it)
    // costs little for shadows that fall where everything is already hidden, and stops at the
    // first shadow after which nothing is left: among many blockers (a street between
    // buildings) most points see little. The largest shadows go first.
    thread_local std::vector<std::pair<double, int>> order;
    order.clear();
    for (std::size_t k = 0; k < shadows.size(); ++k)
        order.emplace_back(-area2(shadows[k]), static_cast<int>(k));
    std::sort(order.begin(), order.end());
    thread_local std::vector<std::array<double, 4>> frag_box, next_box;
    frags.clear();
    frag_box.clear();
    frags.push_back(whole);
    frag_box.push_back(box_of(whole));
    bool cut = false;  // some shadow took a part above the sliver size
    for (const auto& [neg_area, k] : order) {
        const Poly2& sh = shadows[static_cast<std::size_t>(k)];
        const std::array<double, 4> bs = box_of(sh);
        next.clear();
        next_box.clear();
        for (std::size_t f = 0; f < frags.size(); ++f) {
            const std::array<double, 4>& bf = frag_box[f];
            if (apart(bf, bs)) {
                next.push_back(frags[f]);
                next_box.push_back(bf);
                continue;
            }
            const std::size_t first = next.size();
            const double taken = subtract(frags[f], sh, next);
            if (taken > tiny_area) cut = true;
            if (!(taken > tiny_area)) {
                // Nothing taken: the fragment stays whole (not as the pieces the clipping cut
                // it into, which would add rounding and work).
                next.resize(first);
                next.push_back(frags[f]);
                next_box.push_back(bf);
                continue;
            }
            std::size_t kept = first;
            for (std::size_t m = first; m < next.size(); ++m)
                if (area2(next[m]) > tiny_area) {
                    if (kept != m) copy2(next[m], next[kept]);
                    ++kept;
                }
            next.resize(kept);
            for (std::size_t m = first; m < kept; ++m) next_box.push_back(box_of(next[m]));
        }
        std::swap(frags, next);
        std::swap(frag_box, next_box);
        if (frags.empty()) break;
    }
    if (!cut) return res;
    res.all_hidden = frags.empty();
    const double seen_all = want_unobstructed ? res.unobstructed : lambert2(whole, xl, nl);
    double seen = 0.0;
    for (const Poly2& f : frags) seen += lambert2(f, xl, nl);
    res.hidden = std::max(0.0, seen_all - seen);
    return res;
}

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
            for (int e = 0; e < q.n && cur->n >= 3; ++e) {
                const auto a = static_cast<std::size_t>(e);
                const auto b = static_cast<std::size_t>(e + 1 == q.n ? 0 : e + 1);
                const double ex = q.x[b] - q.x[a], ey = q.y[b] - q.y[a];
                if (ex == 0.0 && ey == 0.0) continue;
                clip2(*cur, q.x[a], q.y[a], ex, ey, sign, *tmp);
                std::swap(cur, tmp);
            }
        }
        if (cur->n < 3) continue;
        if (area2(*cur) < 0.0) {
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
    frags.push_back(whole);
    if (area2(frags[0]) < 0.0) {
        std::reverse(frags[0].x.begin(), frags[0].x.begin() + frags[0].n);
        std::reverse(frags[0].y.begin(), frags[0].y.begin() + frags[0].n);
    }
    for (const Poly2& u : umbrae) {
        next.clear();
        for (const Poly2& f : frags) subtract(f, u, next);
        frags.clear();
        for (const Poly2& f : next)
            if (std::abs(area2(f)) > left_over) frags.push_back(f);
        if (frags.empty()) return true;
    }
    return true;
}

bool cell_hidden(const Receiver& rc, const Vec3* poly, int np, const Vec3& nx,
                 const BlockerSet& blockers, const int* cand, int count, double eps) {
    thread_local std::vector<Poly2> frags;
    return umbra_remainder(rc, poly, np, nx, blockers, cand, count, eps, frags) && frags.empty();
}

// Cells where the shaft test finds a blocker but no sample point sees a shadow get their whole
// unobstructed contribution as the error estimate (forcing subdivision) down to this level; below
// it such a shadow is a sliver along a shadow boundary, whose part the normal estimate covers.
constexpr int kSuspiciousLevels = 4;

// Squared distance between the segments p0 p1 and q0 q1 (the closest pair of points, clamped
// to both segments).
double segment_distance2(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
    const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
    const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
    double sp = 0.0, tq = 0.0;
    if (a <= 0.0 && e <= 0.0) return r.squaredNorm();
    if (a <= 0.0) {
        tq = std::clamp(f / e, 0.0, 1.0);
    } else {
        const double c = d1.dot(r);
        if (e <= 0.0) {
            sp = std::clamp(-c / a, 0.0, 1.0);
        } else {
            const double b = d1.dot(d2), den = a * e - b * b;
            sp = den > 0.0 ? std::clamp((b * f - c * e) / den, 0.0, 1.0) : 0.0;
            tq = (b * sp + f) / e;
            if (tq < 0.0) {
                tq = 0.0;
                sp = std::clamp(-c / a, 0.0, 1.0);
            } else if (tq > 1.0) {
                tq = 1.0;
                sp = std::clamp((b - c) / a, 0.0, 1.0);
            }
        }
    }
    return (p0 + sp * d1 - (q0 + tq * d2)).squaredNorm();
}

// Squared distance from x to the planar convex polygon p (n vertices): to its plane when x
// projects inside it, else to its nearest edge.
double point_polygon_distance2(const Vec3& x, const Vec3* p, int n) {
    double best = INFINITY;
    for (int k = 0; k < n; ++k)
        best = std::min(best, segment_distance2(x, x, p[k], p[k + 1 == n ? 0 : k + 1]));
    if (n < 3) return best;
    Vec3 nrm = Vec3::Zero();
    for (int k = 0; k < n; ++k) nrm += p[k].cross(p[k + 1 == n ? 0 : k + 1]);
    const double len = nrm.norm();
    if (!(len > 0.0)) return best;
    nrm /= len;
    bool inside = true;
    for (int k = 0; k < n && inside; ++k) {
        const Vec3& a = p[k];
        const Vec3& b = p[k + 1 == n ? 0 : k + 1];
        inside = (b - a).cross(x - a).dot(nrm) >= 0.0;
    }
    if (!inside) return best;
    const double h = nrm.dot(x - p[0]);
    return std::min(best, h * h);
}

// A lower bound on the distance between two planar convex polygons (exact when they do not
// intersect): the closest of vertex-polygon and edge-edge distances; 0 when they meet.
double polygon_distance(const Vec3* a, int na, const Vec3* b, int nb) {
    double best = INFINITY;
    for (int i = 0; i < na; ++i) best = std::min(best, point_polygon_distance2(a[i], b, nb));
    for (int j = 0; j < nb; ++j) best = std::min(best, point_polygon_distance2(b[j], a, na));
    for (int i = 0; i < na; ++i)
        for (int j = 0; j < nb; ++j)
            best = std::min(best, segment_distance2(a[i], a[i + 1 == na ? 0 : i + 1], b[j],
                                                    b[j + 1 == nb ? 0 : j + 1]));
    // Two polygons that cross each other have every such distance > 0: test an edge of each
    // through the other's interior.
    auto pierces = [](const Vec3* p, int np, const Vec3* q, int nq) {
        if (nq < 3) return false;
        const Vec3 nrm = (q[1] - q[0]).cross(q[2] - q[0]);
        for (int i = 0; i < np; ++i) {
            const Vec3& e0 = p[i];
            const Vec3& e1 = p[i + 1 == np ? 0 : i + 1];
            const double h0 = nrm.dot(e0 - q[0]), h1 = nrm.dot(e1 - q[0]);
            if ((h0 < 0.0) == (h1 < 0.0) || h0 == h1) continue;
            const Vec3 x = e0 + (e1 - e0) * (h0 / (h0 - h1));
            bool inside = true;
            for (int k = 0; k < nq && inside; ++k)
                inside = (q[k + 1 == nq ? 0 : k + 1] - q[k]).cross(x - q[k]).dot(nrm) >= 0.0;
            if (inside) return true;
        }
        return false;
    };
    if (pierces(a, na, b, nb) || pierces(b, nb, a, na)) return 0.0;
    return std::sqrt(best);
}

// The tensor Gauss–Legendre rules of a cell: the result is the highest order's, the larger
// difference between consecutive orders its error estimate.
constexpr int kLowOrder = 2, kMidOrder = 3, kHighOrder = 4;
// How much the difference of orders 2 and 3 is trusted on its own: the worst underestimate of
// a cell's error by that difference seen in the tests was 44× (orders 2 and 3 within 4e-8 of
// each other, 1.75e-6 from the integral), so a difference 50× below the target is taken as
// enough, with 50× the difference as the estimate.
constexpr double kAgreement = 50.0;
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

VisibleBound visible_bound(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                           const int* cand, int n, double eps, double give_up) {
    VisibleBound out;
    const double area_s = area(s);
    const int np = static_cast<int>(s.size());
    if (!(area_s > 0.0) || n == 0 || np < 3 || np > 4) return out;
    const Vec3 ns = normal(s);
    const Receiver rc(r);
    thread_local std::vector<Poly2> frags;
    if (!umbra_remainder(rc, s.vertices.data(), np, ns, blockers, cand, n, eps, frags)) return out;
    out.ok = true;
    if (frags.empty()) return out;
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
    const Vec3 nl(ns.dot(rc.u), ns.dot(rc.v), ns.dot(rc.n));
    auto at = [&](double u, double v, double& w) {
        const Vec3 x = m.at(u, v);
        const Vec3 xr = x - rc.o;
        w *= m.jacobian(u, v);
        return std::make_pair(x, Vec3(rc.u.dot(xr), rc.v.dot(xr), rc.n.dot(x) - rc.d));
    };
    auto rule = [&](const GaussRule& g, int order) {
        double q = 0.0;
        for (int i = 0; i < order; ++i)
            for (int j = 0; j < order; ++j) {
                double w = g.w[static_cast<std::size_t>(i)] * g.w[static_cast<std::size_t>(j)];
                const auto [x, xl] =
                    at(g.x[static_cast<std::size_t>(i)], g.x[static_cast<std::size_t>(j)], w);
                if (!(xl.z() > 0.0)) continue;
                double f = 0.0;
                for (const Poly2& p : frags) f += lambert2(p, xl, nl);
                q += w * f;
            }
        return q / area_s;
    };
    const CellRules rules;
    const double q2 = rule(rules.g2, kLowOrder);
    if (q2 > give_up) {
        out.bound = q2;
        return out;
    }
    const double q3 = rule(rules.g3, kMidOrder);
    out.bound = q3 + kAgreement * std::abs(q3 - q2);
    if (out.bound > give_up) return out;
    // What the sender sees past the blockers, at the 2 × 2 points: an estimate inside the bound.
    double seen = 0.0;
    for (int i = 0; i < kLowOrder; ++i)
        for (int j = 0; j < kLowOrder; ++j) {
            double w =
                rules.g2.w[static_cast<std::size_t>(i)] * rules.g2.w[static_cast<std::size_t>(j)];
            const auto [x, xl] = at(rules.g2.x[static_cast<std::size_t>(i)],
                                    rules.g2.x[static_cast<std::size_t>(j)], w);
            const PointResult pr = evaluate_point(rc, x, ns, blockers, cand, n, eps, true);
            ++out.points;
            seen += w * std::max(0.0, pr.unobstructed - pr.hidden);
        }
    out.estimate = std::clamp(seen / area_s, 0.0, out.bound);
    return out;
}

HiddenIntegral hidden_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                               const int* cand, int n, double target, double eps) {
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
        const double du = c.u1 - c.u0, dv = c.v1 - c.v0;
        const double scale = du * dv * inv_area;
        // The cell's share of the target: its part of the sender's area (the 2 × 2 rule
        // integrates the bilinear and the collapsed map's Jacobians exactly), so that the cells
        // that end by agreement of orders 2 and 3 never add up to more than the target.
        double frac = 0.0;
        for (std::size_t i = 0; i < kLowOrder; ++i)
            for (std::size_t j = 0; j < kLowOrder; ++j)
                frac += rules.g2.w[i] * rules.g2.w[j] *
                        m.jacobian(c.u0 + du * rules.g2.x[i], c.v0 + dv * rules.g2.x[j]);
        frac *= scale;
        // Hidden: the cell's whole unobstructed part. F(x → r) is smooth on the cell: orders 2
        // and 3 of it agreeing kAgreement times better than the cell's share of the target (as
        // for a partly hidden cell below) give its integral for 13 evaluations of Lambert's
        // formula; else the closed form, whose edge integrals resolved to 1e-16 cost many times
        // more.
        // A cell that sees nothing of the receiver: its whole unobstructed part.
        // known_q2: order 2 of it when the caller has it already (< 0: not).
        auto whole_cell = [&](double known_q2) {
            ++out.closed_forms;
            double q2 = 0.0, q3 = 0.0;
            auto unobstructed_rule = [&](const GaussRule& g, int order, double& q) {
                for (int i = 0; i < order; ++i)
                    for (int j = 0; j < order; ++j) {
                        const double u = c.u0 + du * g.x[static_cast<std::size_t>(i)];
                        const double v = c.v0 + dv * g.x[static_cast<std::size_t>(j)];
                        const double w = g.w[static_cast<std::size_t>(i)] *
                                         g.w[static_cast<std::size_t>(j)] * m.jacobian(u, v);
                        q += w * evaluate_point(rc, m.at(u, v), ns, blockers, nullptr, 0, eps, true)
                                     .unobstructed;
                        ++out.points;
                    }
            };
            if (known_q2 >= 0.0)
                q2 = known_q2;
            else
                unobstructed_rule(rules.g2, kLowOrder, q2);
            unobstructed_rule(rules.g3, kMidOrder, q3);
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
            whole_cell(-1.0);
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
        double q2 = 0.0, q3 = 0.0, u3 = 0.0;
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
        auto rule = [&](const GaussRule& g, int order, double& q) {
            for (int i = 0; i < order; ++i)
                for (int j = 0; j < order; ++j) {
                    const double u = c.u0 + du * g.x[static_cast<std::size_t>(i)];
                    const double v = c.v0 + dv * g.x[static_cast<std::size_t>(j)];
                    const PointResult pr = f(u, v);
                    const double val = pr.hidden;
                    any_hidden = any_hidden || pr.hidden > 0.0;
                    any_visible = any_visible || !pr.all_hidden;
                    q += g.w[static_cast<std::size_t>(i)] * g.w[static_cast<std::size_t>(j)] *
                         m.jacobian(u, v) * val;
                }
        };
        rule(rules.g2, kLowOrder, q2);
        if (any_hidden && !any_visible &&
            cell_hidden(rc, poly, np, ns, blockers, cell_cand.data(),
                        static_cast<int>(cell_cand.size()), eps)) {
            // The umbrae of the candidates cover the receiver from the whole cell (no gap of
            // light between their shadows anywhere in it): a hidden cell after all.
            ++out.proven_hidden;
            whole_cell(q2);  // order 2 saw nothing: its hidden part was the whole
            return;
        }
        if (any_hidden && !any_visible) {
            // Orders 2 and 4 first where order 2's points see nothing of the receiver (in the
            // shadow of several buildings together: most cells of a partly hidden pair in an
            // urban array). Where order 4's see nothing either, the integrand at all 20 points
            // is F(x → r), smooth, and order 3 is not needed; the 16 points of order 4 are the
            // ones that find a gap of light between two shadows (13 points of orders 2 and 3
            // were seen to miss such gaps).
            rule(rules.g4, kHighOrder, q4);
            if (!any_visible) {
                c.value = q4 * scale;
                c.error = std::abs(q4 - q2) * scale;
                return;
            }
            rule(rules.g3, kMidOrder, q3);
            c.value = q4 * scale;
            c.error = std::max(std::abs(q4 - q3), std::abs(q3 - q2)) * scale;
            return;
        }
        rule(rules.g3, kMidOrder, q3);
        // Orders 2 and 3 agreeing kAgreement times better than the cell's share of the target:
        // order 3 is taken with kAgreement × their difference as its error, without order 4's
        // 16 points. Where the target is loose (--tolerance 1e-4) most smooth pieces end here.
        const double e23 = std::abs(q3 - q2) * scale;
        // Only where the points see both shadow and light: samples that all fall in the umbra
        // (or all in the light) of a partly hidden cell agree whatever lies between them.
        if (any_hidden && any_visible && kAgreement * e23 <= target * frac) {
            c.value = q3 * scale;
            c.error = kAgreement * e23;
        } else if (e23 > target) {
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
        if (!any_hidden && c.level < kSuspiciousLevels) {
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
                for (std::size_t i = 0; i < kMidOrder; ++i)
                    for (std::size_t j = 0; j < kMidOrder; ++j) {
                        const double u = c.u0 + du * rules.g3.x[i], v = c.v0 + dv * rules.g3.x[j];
                        const PointResult pr =
                            evaluate_point(rc, m.at(u, v), ns, blockers, nullptr, 0, eps, true);
                        u3 += rules.g3.w[i] * rules.g3.w[j] * m.jacobian(u, v) * pr.unobstructed;
                    }
                double cell_area = 0.0;
                if (share < 1.0)
                    for (std::size_t i = 0; i < kMidOrder; ++i)
                        for (std::size_t j = 0; j < kMidOrder; ++j)
                            cell_area +=
                                rules.g3.w[i] * rules.g3.w[j] *
                                m.jacobian(c.u0 + du * rules.g3.x[i], c.v0 + dv * rules.g3.x[j]);
                c.error = std::max(
                    c.error, share < 1.0 ? std::min(u3, share * cell_area) * scale : u3 * scale);
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
