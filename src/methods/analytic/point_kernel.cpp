// The point kernel of the obstructed analytic method: F from a point x to the part of a
// receiver that the candidate blocker pieces hide. Each piece is clipped to the pyramid from x
// over the receiver and projected from x onto the receiver's plane (its shadow); the front faces
// of a convex solid seen from outside merge into one silhouette; the hidden part is Lambert's
// formula (the closed form of the point-to-polygon factor, Hottel & Sarofim 1967) over the union
// of the shadows, or F(x → r) less it over what stays visible. Exact up to rounding: the
// integrand of the adaptive integration in hidden_integral.cpp. See docs/analytic.md,
// "Obstructed scenes".

#include "methods/analytic/point_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"

namespace formfactor::detail {

namespace {

// Up to this many shadows at a point, the hidden part is Lambert's formula over their union;
// above it, F(x → r) less Lambert's formula over what remains visible (see evaluate_point()).
constexpr std::size_t kUnionShadows = 3;

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
    // Both lists usually come in order already (the pieces of a solid are candidates in runs).
    // The order of one solid's raw points does not matter: its hull sorts them.
    if (!std::is_sorted(by_solid.begin(), by_solid.end()))
        std::sort(by_solid.begin(), by_solid.end());
    if (raw.empty()) {
        if (by_solid.size() < 2) return;
        bool repeated = false;
        for (std::size_t g = 1; g < by_solid.size() && !repeated; ++g)
            repeated = by_solid[g].first == by_solid[g - 1].first;
        if (!repeated) return;
    } else {
        const auto by_solid_index = [](const SolidPoint& p, const SolidPoint& q) {
            return p.solid < q.solid;
        };
        if (!std::is_sorted(raw.begin(), raw.end(), by_solid_index))
            std::sort(raw.begin(), raw.end(), by_solid_index);
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
            append2(out, shadows[static_cast<std::size_t>(by_solid[s].second)]);
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
                append2(out, shadows[static_cast<std::size_t>(by_solid[m].second)]);
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
            append2(out, shadows[k]);
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

}  // namespace

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
        // The piece's part between x and the receiver's plane (a piece within eps of that plane
        // hides nothing) and inside the pyramid: the piece's own vertices until a plane cuts it,
        // then the free one of buf.
        const Vec3* cv = pv;
        int cn = pc.count;
        std::size_t free_buf = 0;
        auto cut = [&](const Vec3& nrm, double off) {
            if (!clip3_cut(cv, cn, nrm, off, buf[free_buf])) return;
            cv = buf[free_buf].v.data();
            cn = buf[free_buf].n;
            free_buf ^= 1;
        };
        cut(rc.n, rc.d + eps);
        for (int s = 0; s < sides && cn >= 3; ++s)
            cut(side[static_cast<std::size_t>(s)], side_off[static_cast<std::size_t>(s)]);
        if (cn < 3) continue;
        shadows.emplace_back();
        solid_of.push_back(culled_solid ? pc.solid : -2 - pk);
        Poly2& q = shadows.back();
        q.n = cn;
        for (int k = 0; k < cn; ++k) {
            const Vec3& y = cv[k];
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
    // Of the unclipped faces' vertices, those on the boundary of the region they cover, each
    // once: the start of an edge towards a face that is not among them. Around a vertex whose
    // faces are all projected unclipped, their projections (front faces of a convex solid seen
    // from outside) cover a neighbourhood of its projection, so it is no corner of the hull. The
    // region's boundary edges, directed as their faces go round (a closed solid's faces agree),
    // form closed loops, so every vertex on it starts one of them; the vertex is not taken again
    // from the face whose edge ends there (half the hull's points to sort on a faceted sphere).
    // (A neighbour unknown, −1, counts as a face that is not among them.)
    for (const int pk : raw_faces) {
        const auto& pc = blockers.piece(pk);
        const Vec3* pv = blockers.vertices(pk);
        for (int k = 0; k < pc.count; ++k) {
            const int nb = blockers.neighbor(pk, k);
            if (nb >= 0 && raw_mark[static_cast<std::size_t>(nb)] == raw_epoch) continue;
            const Vec3& y = pv[k];
            const double den = h - (rc.n.dot(y) - rc.d);
            const Vec3 w = x + (h / den) * (y - x) - rc.o;
            raw.push_back({pc.solid, rc.u.dot(w), rc.v.dot(w)});
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
    if (!clip3_cut(rc.poly.v.data(), rc.poly.n, nx, nx.dot(x), rp)) {
        // All of the receiver is in front: its coordinates are known.
        rp.n = rc.poly.n;
        std::copy(rc.poly.v.begin(), rc.poly.v.begin() + rp.n, rp.v.begin());
        copy2(rc.flat, whole);
        return rp.n >= 3;
    }
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
        // The solid that hid the last point this thread evaluated first, when it is among the
        // candidates: the points of a cell come one after another, and where one is behind a
        // building so are its neighbours (the answer is the same whichever solid gives it).
        thread_local int last_hider = -1;
        int tried[4] = {-1, -1, -1, -1};
        int hider = -1;
        auto try_solid = [&](int so) {
            std::rotate(std::begin(tried), std::begin(tried) + 3, std::end(tried));
            tried[0] = so;
            if (blockers.solid_hides(so, &x, 1, rp.v.data(), rp.n)) hider = so;
        };
        if (last_hider >= 0) {
            bool among = false;
            for (int c = 0; c < count && !among; ++c)
                among = blockers.piece(cand[c]).solid == last_hider;
            if (among) try_solid(last_hider);
        }
        for (int c = 0; c < count && hider < 0; ++c) {
            const int so = blockers.piece(cand[c]).solid;
            if (so >= 0 && std::find(std::begin(tried), std::end(tried), so) == std::end(tried))
                try_solid(so);
        }
        if (hider >= 0) {
            last_hider = hider;
            res.hidden = want_unobstructed ? res.unobstructed : lambert2(whole, xl, nl);
            res.all_hidden = true;
            return res;
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
        auto takes_nothing = [&](std::size_t l, std::size_t k) {
            return (solid_of[k] >= 0 && solid_of[k] == solid_of[l]) || apart(boxes[l], boxes[k]);
        };
        for (std::size_t k = 0; k < shadows.size(); ++k) {
            // No earlier shadow to subtract: shadow k is its own fragment.
            std::size_t first_cut = 0;
            while (first_cut < k && takes_nothing(first_cut, k)) ++first_cut;
            if (first_cut == k) {
                const double af = area2(shadows[k]);
                if (af > tiny_area) {
                    res.hidden += lambert2(shadows[k], xl, nl);
                    covered += af;
                }
                continue;
            }
            frags.clear();
            append2(frags, shadows[k]);
            for (std::size_t l = first_cut; l < k && !frags.empty(); ++l) {
                if (takes_nothing(l, k)) continue;
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
    append2(frags, whole);
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
                append2(next, frags[f]);
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
                append2(next, frags[f]);
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

}  // namespace formfactor::detail
