#pragma once
// Where a blocker vertex's shadow falls, for the event filter of split_by_events()
// (discontinuity_mesh.cpp): the sender points from which the vertex's shadow lands on the
// receiver (shadow_region()), and the tests within a tolerance of a point against a plane
// (in_plane()), a plane against the receiver (plane_meets()) and a point against the receiver
// (on_polygon()) by which an event is kept or left out. Inline, for discontinuity_mesh.cpp alone:
// out of line they cost 0.2% more instructions (cornell --subdivide 6 at 1e-6).

#include <algorithm>
#include <cmath>

#include "methods/analytic/shadow_clip.h"

namespace formfactor::detail {

/// The sender points (plane ns·y = ds, 2D frame o, su, sv) from which the line through the
/// point w (in front of the sender) meets the convex polygon r beyond w, intersected with the
/// sender s (counter-clockwise, 2D): r's part farther from the sender's plane than w,
/// projected centrally through w onto the sender's plane. False when that set is empty.
inline bool shadow_region(const Poly3& r, const Vec3& w, const Vec3& ns, double ds, const Vec3& su,
                          const Vec3& sv, const Vec3& o, const Poly2& s, Poly2& out) {
    const double hw = ns.dot(w) - ds;
    Poly3 above;
    // Points just above w's height project very far away: 1e-9 of the height leaves out only
    // what lands beyond 1e9 times the vertex's distance to the receiver.
    clip3(r, ns, ds + hw * (1.0 + 1e-9), above);
    if (above.n < 3) return false;
    Poly2 q;
    q.n = above.n;
    for (int k = 0; k < above.n; ++k) {
        const Vec3& p = above.v[static_cast<std::size_t>(k)];
        const double hp = ns.dot(p) - ds;
        const Vec3 x = p + (w - p) * (hp / (hp - hw)) - o;
        q.x[static_cast<std::size_t>(k)] = su.dot(x);
        q.y[static_cast<std::size_t>(k)] = sv.dot(x);
    }
    if (area2(q) < 0.0) {
        std::reverse(q.x.begin(), q.x.begin() + q.n);
        std::reverse(q.y.begin(), q.y.begin() + q.n);
    }
    // q ∩ s, clipped by s's edges.
    Poly2 buf[2];
    copy2(q, buf[0]);
    Poly2* cur = &buf[0];
    Poly2* nxt = &buf[1];
    for (int k = 0; k < s.n && cur->n >= 3; ++k) {
        const int m = k + 1 == s.n ? 0 : k + 1;
        const double ax = s.x[static_cast<std::size_t>(k)], ay = s.y[static_cast<std::size_t>(k)];
        clip2(*cur, ax, ay, s.x[static_cast<std::size_t>(m)] - ax,
              s.y[static_cast<std::size_t>(m)] - ay, 1.0, *nxt);
        std::swap(cur, nxt);
    }
    if (cur->n < 3) return false;
    copy2(*cur, out);
    return true;
}

/// True when the point q lies within tol of the plane through p with normal m (not
/// normalised).
inline bool in_plane(const Vec3& m, const Vec3& p, const Vec3& q, double tol) {
    return std::abs(m.dot(q - p)) <= tol * m.norm();
}

/// True when the plane through p with normal m (not normalised) meets the polygon r or comes
/// within tol of it.
inline bool plane_meets(const Vec3& m, const Vec3& p, const Poly3& r, double tol) {
    const double mt = tol * m.norm();
    bool pos = false, neg = false;
    for (int k = 0; k < r.n; ++k) {
        const double d = m.dot(r.v[static_cast<std::size_t>(k)] - p);
        pos = pos || d >= -mt;
        neg = neg || d <= mt;
    }
    return pos && neg;
}

/// True when the point w of the plane of the convex polygon r (normal n, counter-clockwise)
/// lies in r or within tol of it.
inline bool on_polygon(const Poly3& r, const Vec3& n, const Vec3& w, double tol) {
    for (int k = 0; k < r.n; ++k) {
        const Vec3& a = r.v[static_cast<std::size_t>(k)];
        const Vec3& b = r.v[static_cast<std::size_t>(k + 1 == r.n ? 0 : k + 1)];
        const Vec3 e = b - a;
        const double el = e.norm();
        if (!(el > 0.0)) continue;
        if (n.dot(e.cross(w - a)) < -tol * el) return false;
    }
    return true;
}

}  // namespace formfactor::detail
