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

Convexity convexity(const Polygon& p) {
    const std::size_t m = p.size();
    if (m < 3) return Convexity::not_convex;
    const Vec3 n = normal(p);
    bool strict = true;
    for (std::size_t k = 0; k < m; ++k) {
        const Vec3 e0 = p[k] - p[(k + m - 1) % m], e1 = p[(k + 1) % m] - p[k];
        const double turn = e0.cross(e1).dot(n), tol = kConvexityTolerance * e0.norm() * e1.norm();
        if (turn < -tol) return Convexity::not_convex;
        if (turn <= tol) {
            if (e0.dot(e1) < 0.0) return Convexity::not_convex;
            strict = false;
        }
    }
    return strict ? Convexity::strictly_convex : Convexity::convex;
}

bool is_convex(const Polygon& p) { return convexity(p) != Convexity::not_convex; }

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
    for (std::size_t k = 0; k < p.size(); ++k)
        m = std::max(m, (p[(k + 1) % p.size()] - p[k]).norm());
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
    while (clean.size() > 1 &&
           (clean.vertices.front() - clean.vertices.back()).squaredNorm() == 0.0)
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
    while (idx.size() > 3 &&
           guard < 4 * static_cast<std::size_t>(n) * static_cast<std::size_t>(n)) {
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

// ---- Convex partitions and holes -------------------------------------------------------------

namespace {

// Is the 2D cycle (indices into q) convex? Collinear corners are allowed, spikes are not.
bool convex_cycle(const std::vector<Vec2>& q, const std::vector<int>& c) {
    const std::size_t m = c.size();
    for (std::size_t k = 0; k < m; ++k) {
        const Vec2& a = q[static_cast<std::size_t>(c[(k + m - 1) % m])];
        const Vec2& b = q[static_cast<std::size_t>(c[k])];
        const Vec2& d = q[static_cast<std::size_t>(c[(k + 1) % m])];
        const Vec2 e0 = b - a, e1 = d - b;
        const double cr = cross2(e0, e1), tol = kConvexityTolerance * e0.norm() * e1.norm();
        if (cr < -tol) return false;
        if (cr <= tol && e0.dot(e1) < 0.0) return false;
    }
    return true;
}

// Removes repeated and collinear corners (and zero-width spikes) left by clipping.
Polygon clean_piece(Polygon p, double eps) {
    bool changed = true;
    while (changed && p.size() >= 3) {
        changed = false;
        const std::size_t m = p.size();
        for (std::size_t k = 0; k < m; ++k) {
            const Vec3& a = p[(k + m - 1) % m];
            const Vec3& b = p[k];
            const Vec3& c = p[(k + 1) % m];
            const Vec3 e0 = b - a, e1 = c - b;
            const bool repeated = e0.norm() <= eps;
            const bool collinear = e0.cross(e1).norm() <= 1e-14 * e0.norm() * e1.norm();
            if (repeated || collinear) {
                p.vertices.erase(p.vertices.begin() + static_cast<std::ptrdiff_t>(k));
                changed = true;
                break;
            }
        }
    }
    if (p.size() < 3) p.vertices.clear();
    return p;
}

}  // namespace

std::vector<std::vector<int>> convex_partition(const Polygon& p) {
    std::vector<std::vector<int>> parts;
    const std::size_t n = p.size();
    if (n < 3) return parts;
    const std::vector<Vec2> q = to_plane(p);
    std::vector<int> all(n);
    for (std::size_t k = 0; k < n; ++k) all[k] = static_cast<int>(k);
    if (convex_cycle(q, all)) {
        parts.push_back(std::move(all));
        return parts;
    }
    const double d = diameter(p);
    for (const auto& t : triangulate(p)) {
        Polygon tri{{p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                     p[static_cast<std::size_t>(t[2])]}};
        if (area(tri) > 1e-14 * d * d) parts.push_back({t[0], t[1], t[2]});
    }
    // Hertel–Mehlhorn: drop a diagonal u–v shared by two parts when their union stays convex.
    bool merged = true;
    while (merged) {
        merged = false;
        for (std::size_t a = 0; a < parts.size() && !merged; ++a) {
            for (std::size_t b = a + 1; b < parts.size() && !merged; ++b) {
                const std::vector<int>& A = parts[a];
                const std::vector<int>& B = parts[b];
                for (std::size_t k = 0; k < A.size() && !merged; ++k) {
                    const int u = A[k], v = A[(k + 1) % A.size()];
                    for (std::size_t l = 0; l < B.size(); ++l) {
                        if (B[l] != v || B[(l + 1) % B.size()] != u) continue;
                        // v, ..., u around A, then B's corners after u up to before v.
                        std::vector<int> m;
                        for (std::size_t s = 0; s < A.size(); ++s)
                            m.push_back(A[(k + 1 + s) % A.size()]);
                        for (std::size_t s = 2; s < B.size(); ++s)
                            m.push_back(B[(l + s) % B.size()]);
                        if (convex_cycle(q, m)) {
                            parts[a] = std::move(m);
                            parts.erase(parts.begin() + static_cast<std::ptrdiff_t>(b));
                            merged = true;
                        }
                        break;
                    }
                }
            }
        }
    }
    return parts;
}

std::vector<Polygon> subtract_holes(const Polygon& p, const std::vector<Polygon>& holes) {
    std::vector<Polygon> pieces;
    if (p.size() < 3) return pieces;
    const Vec3 n = normal(p);
    const Plane pl = plane_of(p);
    const double d = diameter(p);
    const double eps = 1e-12 * d;
    const double min_area = 1e-15 * d * d;
    for (const auto& part : convex_partition(p)) {
        Polygon piece;
        for (int k : part) piece.vertices.push_back(p[static_cast<std::size_t>(k)]);
        pieces.push_back(std::move(piece));
    }
    for (const Polygon& h : holes) {
        if (h.size() < 3) continue;
        // The hole in p's plane, counter-clockwise about p's normal.
        Polygon flat;
        for (const Vec3& v : h.vertices) flat.vertices.push_back(v - pl.signed_distance(v) * n);
        if (area_vector(flat).dot(n) < 0.0)
            std::reverse(flat.vertices.begin(), flat.vertices.end());
        for (const auto& part : convex_partition(flat)) {
            Polygon c;
            for (int k : part) c.vertices.push_back(flat[static_cast<std::size_t>(k)]);
            Bounds3 cb = bounds(c);
            cb.lo.array() -= 1e-5 * d;
            cb.hi.array() += 1e-5 * d;
            std::vector<Polygon> next;
            for (Polygon& piece : pieces) {
                const Bounds3 pb = bounds(piece);
                if ((pb.hi.array() < cb.lo.array()).any() ||
                    (pb.lo.array() > cb.hi.array()).any()) {
                    next.push_back(std::move(piece));
                    continue;
                }
                Polygon rest = std::move(piece);
                for (std::size_t k = 0; k < c.size() && rest.size() >= 3; ++k) {
                    const Vec3& a = c[k];
                    const Vec3 m = n.cross(c[(k + 1) % c.size()] - a);
                    const double len = m.norm();
                    if (!(len > 0.0)) continue;
                    Plane inside;  // the hole's side of edge k (its left, seen from the front)
                    inside.n = m / len;
                    inside.d = inside.n.dot(a);
                    const Plane outside{-inside.n, -inside.d};
                    Polygon out = clean_piece(clip_to_front(rest, outside, eps), eps);
                    if (out.size() >= 3 && area(out) > min_area) next.push_back(std::move(out));
                    rest = clip_to_front(rest, inside, eps);
                }
                // What is left of `rest` lies inside the hole.
            }
            pieces = std::move(next);
        }
    }
    std::vector<Polygon> out;
    for (Polygon& piece : pieces) {
        Polygon c = clean_piece(std::move(piece), eps);
        if (c.size() >= 3 && area(c) > min_area) out.push_back(std::move(c));
    }
    return out;
}

double overlap_area(const Polygon& a, const Polygon& b) {
    double rest = 0.0;
    for (const Polygon& piece : subtract_holes(a, {b})) rest += area(piece);
    return std::max(0.0, area(a) - rest);
}

}  // namespace formfactor
