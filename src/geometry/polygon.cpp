#include "formfactor/geometry/polygon.h"

#include <algorithm>
#include <cmath>

namespace formfactor {

Vec3 area_vector(const Polygon& p) {
    Vec3 s = Vec3::Zero();
    const std::size_t n = p.size();
    if (n < 3) return s;
    // Relative to the first vertex: better conditioned far from the origin.
    const Vec3& o = p[0];
    for (std::size_t k = 1; k + 1 < n; ++k) s += (p[k] - o).cross(p[k + 1] - o);
    return 0.5 * s;
}

double area(const Polygon& p) { return area_vector(p).norm(); }

Vec3 normal(const Polygon& p) {
    const Vec3 a = area_vector(p);
    const double len = a.norm();
    return len > 0.0 ? Vec3(a / len) : Vec3(Vec3::Zero());
}

Vec3 centroid(const Polygon& p) {
    const std::size_t n = p.size();
    if (n == 0) return Vec3::Zero();
    const Vec3 nrm = normal(p);
    const Vec3& o = p[0];
    Vec3 c = Vec3::Zero();
    double total = 0.0;
    for (std::size_t k = 1; k + 1 < n; ++k) {
        const double w = 0.5 * (p[k] - o).cross(p[k + 1] - o).dot(nrm);  // signed fan area
        c += w * (o + p[k] + p[k + 1]) / 3.0;
        total += w;
    }
    if (total == 0.0) {
        Vec3 mean = Vec3::Zero();
        for (const Vec3& v : p.vertices) mean += v;
        return mean / static_cast<double>(n);
    }
    return c / total;
}

Plane plane_of(const Polygon& p) {
    Plane pl;
    pl.n = normal(p);
    pl.d = pl.n.dot(centroid(p));
    return pl;
}

Bounds3 bounds(const Polygon& p) {
    Bounds3 b;
    for (const Vec3& v : p.vertices) b.extend(v);
    return b;
}

double max_edge_length(const Polygon& p) {
    double m = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k) m = std::max(m, (p[(k + 1) % p.size()] - p[k]).norm());
    return m;
}

double diameter(const Polygon& p) {
    double m = 0.0;
    for (std::size_t a = 0; a < p.size(); ++a)
        for (std::size_t b = a + 1; b < p.size(); ++b) m = std::max(m, (p[a] - p[b]).norm());
    return m;
}

double planarity_defect(const Polygon& p) {
    const double d = diameter(p);
    if (d == 0.0) return 0.0;
    const Plane pl = plane_of(p);
    double m = 0.0;
    for (const Vec3& v : p.vertices) m = std::max(m, std::abs(pl.signed_distance(v)));
    return m / d;
}

void orthonormal_basis(const Vec3& n, Vec3& u, Vec3& v) {
    // Duff et al. 2017, "Building an Orthonormal Basis, Revisited".
    const double sign = std::copysign(1.0, n.z());
    const double a = -1.0 / (sign + n.z());
    const double b = n.x() * n.y() * a;
    u = Vec3(1.0 + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
    v = Vec3(b, sign + n.y() * n.y() * a, -n.y());
}

PlaneFrame frame_of(const Polygon& p) {
    PlaneFrame f;
    f.origin = centroid(p);
    f.n = normal(p);
    orthonormal_basis(f.n, f.u, f.v);
    return f;
}

namespace {

double cross2(const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); }

// Do closed segments ab and cd share a point? (2D, exact-ish orientation tests)
bool segments_touch(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d, double eps) {
    const double d1 = cross2(b - a, c - a), d2 = cross2(b - a, d - a);
    const double d3 = cross2(d - c, a - c), d4 = cross2(d - c, b - c);
    const double la = (b - a).norm(), lc = (d - c).norm();
    const double e1 = eps * la, e2 = eps * lc;
    auto on_segment = [eps](const Vec2& p, const Vec2& q, const Vec2& r) {
        // r collinear with pq: within the bounding box (inflated)
        const double tol = eps * (q - p).norm();
        return r.x() >= std::min(p.x(), q.x()) - tol && r.x() <= std::max(p.x(), q.x()) + tol &&
               r.y() >= std::min(p.y(), q.y()) - tol && r.y() <= std::max(p.y(), q.y()) + tol;
    };
    if (((d1 > e1 && d2 < -e1) || (d1 < -e1 && d2 > e1)) &&
        ((d3 > e2 && d4 < -e2) || (d3 < -e2 && d4 > e2)))
        return true;
    if (std::abs(d1) <= e1 && on_segment(a, b, c)) return true;
    if (std::abs(d2) <= e1 && on_segment(a, b, d)) return true;
    if (std::abs(d3) <= e2 && on_segment(c, d, a)) return true;
    if (std::abs(d4) <= e2 && on_segment(c, d, b)) return true;
    return false;
}

std::vector<Vec2> to_plane(const Polygon& p) {
    const PlaneFrame f = frame_of(p);
    std::vector<Vec2> q;
    q.reserve(p.size());
    for (const Vec3& v : p.vertices) q.push_back(f.to_local(v));
    return q;
}

}  // namespace

bool is_simple(const Polygon& p) {
    const std::size_t n = p.size();
    if (n < 3) return false;
    const std::vector<Vec2> q = to_plane(p);
    const double scale = diameter(p);
    if (scale == 0.0) return false;
    const double eps = 1e-12;
    for (std::size_t a = 0; a < n; ++a)
        for (std::size_t b = a + 1; b < n; ++b)
            if ((q[a] - q[b]).norm() <= eps * scale) return false;  // repeated vertex
    for (std::size_t a = 0; a < n; ++a) {
        for (std::size_t b = a + 1; b < n; ++b) {
            const bool adjacent = (b == a + 1) || (a == 0 && b == n - 1);
            if (adjacent) continue;
            if (segments_touch(q[a], q[(a + 1) % n], q[b], q[(b + 1) % n], eps)) return false;
        }
    }
    // Adjacent edges that fold back onto each other (a spike) are not simple either.
    for (std::size_t k = 0; k < n; ++k) {
        const Vec2 e0 = q[k] - q[(k + n - 1) % n], e1 = q[(k + 1) % n] - q[k];
        if (std::abs(cross2(e0, e1)) <= eps * e0.norm() * e1.norm() && e0.dot(e1) < 0.0)
            return false;
    }
    return true;
}

Polygon clip_to_front(const Polygon& p, const Plane& plane, double eps) {
    Polygon out;
    const std::size_t n = p.size();
    if (n == 0) return out;
    out.vertices.reserve(n + 2);
    std::vector<double> d(n);
    bool all_in = true;
    for (std::size_t k = 0; k < n; ++k) {
        double s = plane.signed_distance(p[k]);
        if (std::abs(s) <= eps) s = 0.0;
        d[k] = s;
        all_in = all_in && s >= 0.0;
    }
    if (all_in) return p;
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t m = (k + 1) % n;
        const Vec3& a = p[k];
        const Vec3& b = p[m];
        if (d[k] >= 0.0) out.vertices.push_back(a);
        if ((d[k] > 0.0 && d[m] < 0.0) || (d[k] < 0.0 && d[m] > 0.0)) {
            const double t = d[k] / (d[k] - d[m]);
            out.vertices.push_back(a + t * (b - a));
        }
    }
    // Drop consecutive duplicates (vertices on the plane followed by their own intersection).
    Polygon clean;
    for (const Vec3& v : out.vertices)
        if (clean.vertices.empty() || (v - clean.vertices.back()).squaredNorm() > 0.0)
            clean.vertices.push_back(v);
    while (clean.size() > 1 && (clean.vertices.front() - clean.vertices.back()).squaredNorm() == 0.0)
        clean.vertices.pop_back();
    if (clean.size() < 3 || area(clean) == 0.0) clean.vertices.clear();
    return clean;
}

std::vector<std::array<int, 3>> triangulate(const Polygon& p) {
    std::vector<std::array<int, 3>> tris;
    const int n = static_cast<int>(p.size());
    if (n < 3) return tris;
    if (n == 3) return {{0, 1, 2}};
    const std::vector<Vec2> q = to_plane(p);
    std::vector<int> idx(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) idx[static_cast<std::size_t>(k)] = k;
    auto convex = [&](int a, int b, int c) {
        return cross2(q[static_cast<std::size_t>(b)] - q[static_cast<std::size_t>(a)],
                      q[static_cast<std::size_t>(c)] - q[static_cast<std::size_t>(b)]) > 0.0;
    };
    // Points on an ear's edge (within rounding) count as inside, so that an ear never passes
    // through another vertex (which would leave a zero-area sliver behind).
    double scale2 = 0.0;
    for (const Vec2& v : q) scale2 = std::max(scale2, v.squaredNorm());
    const double tol = -1e-12 * scale2;
    auto inside = [&](int a, int b, int c, int x) {
        const Vec2& A = q[static_cast<std::size_t>(a)];
        const Vec2& B = q[static_cast<std::size_t>(b)];
        const Vec2& C = q[static_cast<std::size_t>(c)];
        const Vec2& X = q[static_cast<std::size_t>(x)];
        return cross2(B - A, X - A) >= tol && cross2(C - B, X - B) >= tol &&
               cross2(A - C, X - C) >= tol;
    };
    std::size_t guard = 0;
    while (idx.size() > 3 && guard < 4 * static_cast<std::size_t>(n) * static_cast<std::size_t>(n)) {
        ++guard;
        bool clipped = false;
        const std::size_t m = idx.size();
        for (std::size_t k = 0; k < m; ++k) {
            const int a = idx[(k + m - 1) % m], b = idx[k], c = idx[(k + 1) % m];
            if (!convex(a, b, c)) continue;
            bool ear = true;
            for (int x : idx) {
                if (x == a || x == b || x == c) continue;
                if (inside(a, b, c, x)) {
                    ear = false;
                    break;
                }
            }
            if (!ear) continue;
            tris.push_back({a, b, c});
            idx.erase(idx.begin() + static_cast<std::ptrdiff_t>(k));
            clipped = true;
            break;
        }
        if (!clipped) {
            // Numerically flat remainder: fan it (areas are ~0 anyway).
            break;
        }
    }
    for (std::size_t k = 1; k + 1 < idx.size(); ++k) tris.push_back({idx[0], idx[k], idx[k + 1]});
    return tris;
}

}  // namespace formfactor
