#pragma once
// Small fixed-capacity convex polygons and their clipping, shared by the point kernel
// (point_kernel.cpp: shadows of the blocker pieces on the receiver, their union by fragment
// subtraction, Lambert's formula on the fragments) and the sender's event split
// (discontinuity_mesh.cpp). The small helpers are inline here; clip3, clip2 and lambert2 are
// in shadow_clip.cpp.

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"
#include "methods/analytic/obstructed_internal.h"

namespace formfactor::detail {

/// Capacity of the small polygons of the point evaluation: a convex piece (≤ kMaxPieceVertices)
/// clipped by the receiver's plane and the pyramid's side planes gains one vertex per plane.
inline constexpr int kCap = 2 * kMaxPieceVertices + 8;

/// A convex polygon in space (n vertices).
struct Poly3 {
    int n = 0;
    std::array<Vec3, kCap> v;
};
/// A convex polygon in a plane's 2D coordinates (n vertices). The constructor leaves the
/// coordinates uninitialised: vectors of shadows value-initialise their new elements, which would
/// otherwise zero 2 × kCap doubles per shadow.
struct Poly2 {
    int n = 0;
    std::array<double, kCap> x, y;
    Poly2() noexcept {}  // NOLINT(modernize-use-equals-default): = default would zero x and y
};

/// Keeps the part of `in` where n·y − off ≥ 0 (Sutherland–Hodgman; convex in, convex out).
void clip3(const Poly3& in, const Vec3& n, double off, Poly3& out);
/// clip3() of the convex polygon v[0, count) without the copy when it keeps every vertex:
/// returns false, leaving `out` as it was, when the part is the polygon itself; else writes the
/// part to `out` (n = 0 when empty) and returns true.
bool clip3_cut(const Vec3* v, int count, const Vec3& n, double off, Poly3& out);

/// out = in.
inline void copy2(const Poly2& in, Poly2& out) {
    out.n = in.n;
    std::copy(in.x.begin(), in.x.begin() + in.n, out.x.begin());
    std::copy(in.y.begin(), in.y.begin() + in.n, out.y.begin());
}

/// Appends a copy of p to v, its n vertices only (a whole Poly2 is kCap of each coordinate).
inline void append2(std::vector<Poly2>& v, const Poly2& p) {
    v.emplace_back();
    copy2(p, v.back());
}

/// Keeps the part of `in` on the left of the directed line a → a + e (sign = +1) or on its
/// right (sign = −1).
void clip2(const Poly2& in, double ax, double ay, double ex, double ey, double sign, Poly2& out);
/// Both parts at once: clip2() with sign +1 into `left` and with sign −1 into `right`, the same
/// vertices bit for bit, each vertex's side found once.
void split2(const Poly2& in, double ax, double ay, double ex, double ey, Poly2& left, Poly2& right);
/// split2() without the copy when `in` lies on one side: returns 1 when it is wholly on the left
/// and −1 when wholly on the right (left and right untouched: the part is `in`, the other side
/// empty), else 0 with both parts written (either possibly empty).
int split2_cut(const Poly2& in, double ax, double ay, double ex, double ey, Poly2& left,
               Poly2& right);

/// Signed area (positive when counter-clockwise).
inline double area2(const Poly2& p) {
    double a = 0.0;
    for (int k = 0; k < p.n; ++k) {
        const int m = k + 1 == p.n ? 0 : k + 1;
        a += p.x[static_cast<std::size_t>(k)] * p.y[static_cast<std::size_t>(m)] -
             p.x[static_cast<std::size_t>(m)] * p.y[static_cast<std::size_t>(k)];
    }
    return 0.5 * a;
}

/// f \ s for convex f and convex counter-clockwise s: disjoint convex fragments appended to out.
/// Returns the area of f ∩ s (what the subtraction took). An s whose vertices all coincide (a
/// shadow or an umbra that shrank to the point where a blocker touches the receiver's edge)
/// takes nothing.
inline double subtract(const Poly2& f, const Poly2& s, std::vector<Poly2>& out) {
    // The part of f inside the edges so far: f itself until an edge cuts it, then the free one
    // of buf.
    Poly2 buf[2], outside;
    const Poly2* inside = &f;
    std::size_t free_buf = 0;
    bool any_edge = false;
    for (int k = 0; k < s.n && inside->n >= 3; ++k) {
        const int m = k + 1 == s.n ? 0 : k + 1;
        const auto ks = static_cast<std::size_t>(k), ms = static_cast<std::size_t>(m);
        const double ax = s.x[ks], ay = s.y[ks];
        const double ex = s.x[ms] - ax, ey = s.y[ms] - ay;
        if (ex == 0.0 && ey == 0.0) continue;
        any_edge = true;
        const int side = split2_cut(*inside, ax, ay, ex, ey, buf[free_buf], outside);
        if (side == 1) continue;  // wholly inside this edge
        if (side == -1) {         // wholly outside: all of it is a fragment
            if (area2(*inside) > 0.0) append2(out, *inside);
            return 0.0;
        }
        if (outside.n >= 3 && area2(outside) > 0.0) append2(out, outside);
        inside = &buf[free_buf];
        free_buf ^= 1;
    }
    if (!any_edge) {
        if (f.n >= 3 && area2(f) > 0.0) append2(out, f);
        return 0.0;
    }
    return inside->n >= 3 ? std::abs(area2(*inside)) : 0.0;
}

/// Lambert's formula for a counter-clockwise polygon q in the receiver's plane (local 2D
/// coordinates), seen from the point xl = (u, v, height) with unit normal nl (local coordinates).
double lambert2(const Poly2& q, const Vec3& xl, const Vec3& nl);

/// The receiver of a pair, prepared once: convex polygon, its plane frame, and the polygon in
/// that frame's coordinates (u·(y − o), v·(y − o) per vertex y).
struct Receiver {
    Poly3 poly;
    Vec3 n, o, u, v;
    double d = 0;
    Poly2 flat;
    explicit Receiver(const Polygon& r) {
        FF_ASSERT(r.size() <= static_cast<std::size_t>(kCap));
        poly.n = static_cast<int>(r.size());
        for (std::size_t k = 0; k < r.size(); ++k) poly.v[k] = r[k];
        n = normal(r);
        o = r[0];
        d = n.dot(o);
        orthonormal_basis(n, u, v);
        flat.n = poly.n;
        for (std::size_t k = 0; k < r.size(); ++k) {
            const Vec3 w = poly.v[k] - o;
            flat.x[k] = u.dot(w);
            flat.y[k] = v.dot(w);
        }
    }
};

}  // namespace formfactor::detail
