// Bounds from a sender cell's geometry alone (hidden_integral.cpp): the distance between two
// convex polygons, and an upper bound on the point form factor F(x → r) over the points x of a
// cell, from which a cell's hidden part is bracketed without integration (its unobstructed part
// bounds it; conservative bounds in the manner of Lischinski, Smits & Greenberg 1994). See
// docs/analytic.md, "Cells settled by their brackets".

#include <algorithm>
#include <cmath>

#include "methods/analytic/sender_cells.h"

namespace formfactor::detail {

namespace {

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

}  // namespace

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

double point_factor_bound(const Vec3* cell, int np, const Vec3& ns, const Receiver& rc,
                          double limit) {
    // cos θ_x = (height of y above the sender's plane) / d, the same for every x of the cell;
    // cos θ_r = (height of x above r's plane) / d.
    double h_receiver = 0.0, h_cell = 0.0;
    for (int k = 0; k < rc.poly.n; ++k)
        h_receiver = std::max(h_receiver, ns.dot(rc.poly.v[static_cast<std::size_t>(k)] - cell[0]));
    for (int k = 0; k < np; ++k) h_cell = std::max(h_cell, rc.n.dot(cell[k]) - rc.d);
    if (!(h_cell > 0.0) || !(h_receiver > 0.0)) return 0.0;
    double area_r = 0.0;
    for (int k = 1; k + 1 < rc.poly.n; ++k)
        area_r += 0.5 * (rc.poly.v[static_cast<std::size_t>(k)] - rc.poly.v[0])
                            .cross(rc.poly.v[static_cast<std::size_t>(k + 1)] - rc.poly.v[0])
                            .norm();
    auto bound_at = [&](double d) {
        if (!(d > 0.0)) return 1.0;
        return std::min(1.0, area_r / (kPi * d * d) * std::min(1.0, h_receiver / d) *
                                 std::min(1.0, h_cell / d));
    };
    // The distance between the centroids is at least d_min: the bound at it is at most the
    // bound, and when that already exceeds `limit`, the caller has its answer.
    Vec3 cc = Vec3::Zero(), cr = Vec3::Zero();
    for (int k = 0; k < np; ++k) cc += cell[k];
    for (int k = 0; k < rc.poly.n; ++k) cr += rc.poly.v[static_cast<std::size_t>(k)];
    const double below = bound_at((cc / np - cr / rc.poly.n).norm());
    if (below > limit) return below;
    return bound_at(polygon_distance(cell, np, rc.poly.v.data(), rc.poly.n));
}

}  // namespace formfactor::detail
