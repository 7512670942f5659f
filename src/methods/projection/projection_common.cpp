#include "methods/projection/projection_common.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "formfactor/core/error.h"

namespace formfactor::projection {

namespace {

void add_primitive(Occluders& occ, const std::vector<Vec3>& verts, int item) {
    Polygon poly{verts};
    const Vec3 av = area_vector(poly);
    const double len = av.norm();
    if (!(len > 0.0) || !std::isfinite(len)) return;
    const Vec3 n = av / len;
    Vec3 c = Vec3::Zero();
    for (const Vec3& v : verts) c += v;
    c /= static_cast<double>(verts.size());
    double r = 0.0;
    for (const Vec3& v : verts) r = std::max(r, (v - c).norm());
    for (const Vec3& v : verts) {
        occ.x.push_back(v.x());
        occ.y.push_back(v.y());
        occ.z.push_back(v.z());
    }
    occ.first.push_back(static_cast<std::uint32_t>(occ.x.size()));
    occ.item.push_back(item);
    occ.nx.push_back(n.x());
    occ.ny.push_back(n.y());
    occ.nz.push_back(n.z());
    occ.d.push_back(n.dot(c));
    occ.cx.push_back(c.x());
    occ.cy.push_back(c.y());
    occ.cz.push_back(c.z());
    occ.r.push_back(r * (1.0 + 1e-12));
}

void add_polygon(Occluders& occ, const Polygon& p, int item) {
    if (p.size() < 3) return;
    const Vec3 n = normal(p);
    if (n.squaredNorm() == 0.0) return;
    if (p.size() <= static_cast<std::size_t>(kMaxPrimitiveVertices) && is_convex(p)) {
        add_primitive(occ, p.vertices, item);
        return;
    }
    for (const auto& t : triangulate(p)) {
        add_primitive(occ,
                      {p[static_cast<std::size_t>(t[0])], p[static_cast<std::size_t>(t[1])],
                       p[static_cast<std::size_t>(t[2])]},
                      item);
    }
}

// Bilinear image of (s, t) in the quad q.
Vec3 bilinear(const std::array<Vec3, 4>& q, double s, double t) {
    return (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3];
}

// Gauss–Legendre nodes and weights on [0, 1] (Newton on the Legendre polynomial).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
    x.assign(static_cast<std::size_t>(n), 0.0);
    w.assign(static_cast<std::size_t>(n), 0.0);
    for (int i = 0; i < (n + 1) / 2; ++i) {
        double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
        double dp = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = 0.0;
            for (int j = 1; j <= n; ++j) {
                const double p2 = p1;
                p1 = p0;
                p0 = ((2.0 * j - 1.0) * z * p1 - (j - 1.0) * p2) / j;
            }
            dp = n * (z * p0 - p1) / (z * z - 1.0);
            const double dz = p0 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) break;
        }
        const double wi = 2.0 / ((1.0 - z * z) * dp * dp);
        x[static_cast<std::size_t>(i)] = 0.5 * (1.0 - z);
        x[static_cast<std::size_t>(n - 1 - i)] = 0.5 * (1.0 + z);
        w[static_cast<std::size_t>(i)] = w[static_cast<std::size_t>(n - 1 - i)] = 0.5 * wi;
    }
}

// K points of the quad q (a triangle repeats its last vertex): the Gauss–Legendre product rule
// of rows × cols = K nodes in the bilinear parameters, weighted by the map's Jacobian, the
// weights summing to `scale`.
void quad_points(const std::array<Vec3, 4>& q, int K, double scale,
                 std::vector<WeightedPoint>& out) {
    // ns × nt = K nodes, their ratio as close as possible to the quad's aspect ratio.
    const double len_s = (q[1] - q[0]).norm() + (q[2] - q[3]).norm();
    const double len_t = (q[3] - q[0]).norm() + (q[2] - q[1]).norm();
    const double aspect = len_t > 0.0 && len_s > 0.0 ? std::log(len_s / len_t) : 0.0;
    int ns = K, nt = 1;
    double best = std::numeric_limits<double>::infinity();
    for (int a = 1; a <= K; ++a) {
        if (K % a != 0) continue;
        const double miss = std::abs(std::log(static_cast<double>(a) / (K / a)) - aspect);
        if (miss < best - 1e-12) {
            best = miss;
            ns = a;
            nt = K / a;
        }
    }
    std::vector<double> xs, ws, xt, wt;
    gauss_legendre(ns, xs, ws);
    gauss_legendre(nt, xt, wt);
    const std::size_t start = out.size();
    double total = 0.0;
    for (int j = 0; j < nt; ++j) {
        for (int i = 0; i < ns; ++i) {
            const double s = xs[static_cast<std::size_t>(i)], t = xt[static_cast<std::size_t>(j)];
            const Vec3 ds = (1 - t) * (q[1] - q[0]) + t * (q[2] - q[3]);
            const Vec3 dt = (1 - s) * (q[3] - q[0]) + s * (q[2] - q[1]);
            const double a = ws[static_cast<std::size_t>(i)] * wt[static_cast<std::size_t>(j)] *
                             ds.cross(dt).norm();
            out.push_back({bilinear(q, s, t), a});
            total += a;
        }
    }
    for (std::size_t k = start; k < out.size(); ++k) {
        out[k].weight = total > 0 ? out[k].weight / total * scale
                                  : scale / static_cast<double>(out.size() - start);
    }
}

}  // namespace

Occluders build_occluders(const Scene& scene) {
    Occluders occ;
    occ.patches = scene.patches.size();
    occ.first.push_back(0);
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        add_polygon(occ, scene.patches[i].polygon, static_cast<int>(i));
    }
    for (const Surface& s : scene.surfaces) {
        if (!s.obstruction) continue;
        if (s.holes.empty()) {
            add_polygon(occ, s.polygon, kViewObstruction);
        } else {
            for (const Polygon& piece : subtract_holes(s.polygon, s.holes)) {
                add_polygon(occ, piece, kViewObstruction);
            }
        }
    }
    Bounds3 b;
    for (std::size_t k = 0; k < occ.x.size(); ++k) b.extend(Vec3(occ.x[k], occ.y[k], occ.z[k]));
    const double diag = b.empty() ? 0.0 : b.diagonal().norm();
    occ.scale = diag > 0.0 && std::isfinite(diag) ? diag : 1.0;
    return occ;
}

namespace {

// K points of a polygon with more triangles than K (a disk of hundreds of vertices): the polygon
// is cut in two by a plane across its longer extent, at the place that splits its area in the
// ratio ⌊K/2⌋ : ⌈K/2⌉, and each part gets its share of the points, down to one point per part:
// the part's area centroid (the centroid of its largest triangle when that falls outside a
// non-convex part), weighted by the part's share of the area. K compact cells, one point each: a
// midpoint rule that converges as K grows, whatever the vertex count.
void bisection_points(const Polygon& p, int K, double total, std::vector<WeightedPoint>& out) {
    const double a = area(p);
    if (!(a > 0.0)) return;
    const PlaneFrame f = frame_of(p);
    if (K <= 1) {
        Vec3 c = centroid(p);
        std::vector<Vec2> q;
        for (const Vec3& v : p.vertices) q.push_back(f.to_local(v));
        const Vec2 x = f.to_local(c);
        bool in = false;  // even-odd rule in the polygon's plane
        for (std::size_t i = 0, j = q.size() - 1; i < q.size(); j = i++)
            if ((q[i].y() > x.y()) != (q[j].y() > x.y()) &&
                x.x() <
                    (q[j].x() - q[i].x()) * (x.y() - q[i].y()) / (q[j].y() - q[i].y()) + q[i].x())
                in = !in;
        if (!in) {
            double best = 0.0;
            for (const auto& t : triangulate(p)) {
                const Vec3& u = p[static_cast<std::size_t>(t[0])];
                const Vec3& v = p[static_cast<std::size_t>(t[1])];
                const Vec3& w = p[static_cast<std::size_t>(t[2])];
                const double at = (v - u).cross(w - u).norm();
                if (at > best) {
                    best = at;
                    c = (u + v + w) / 3.0;
                }
            }
        }
        out.push_back({c, a / total});
        return;
    }
    // The longer in-plane extent, and the cut along it by bisection on the area.
    double lo_u = std::numeric_limits<double>::infinity(), hi_u = -lo_u, lo_v = lo_u, hi_v = -lo_u;
    for (const Vec3& v : p.vertices) {
        const Vec2 x = f.to_local(v);
        lo_u = std::min(lo_u, x.x());
        hi_u = std::max(hi_u, x.x());
        lo_v = std::min(lo_v, x.y());
        hi_v = std::max(hi_v, x.y());
    }
    const bool along_u = hi_u - lo_u >= hi_v - lo_v;
    const Vec3 dir = along_u ? f.u : f.v;
    const double o = dir.dot(f.origin);
    double lo = o + (along_u ? lo_u : lo_v), hi = o + (along_u ? hi_u : hi_v);
    const int k1 = K / 2;
    const double want = a * k1 / K;
    auto below = [&](double t) { return clip_to_front(p, Plane{-dir, -t}); };
    for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (area(below(mid)) < want ? lo : hi) = mid;
    }
    const double t = 0.5 * (lo + hi);
    bisection_points(below(t), k1, total, out);
    bisection_points(clip_to_front(p, Plane{dir, t}), K - k1, total, out);
}

}  // namespace

std::vector<WeightedPoint> patch_points(const Polygon& polygon, int K) {
    std::vector<WeightedPoint> out;
    if (K <= 1 || polygon.size() < 3) {
        out.push_back({centroid(polygon), 1.0});
        return out;
    }
    if (polygon.size() == 3) {
        quad_points({polygon[0], polygon[1], polygon[2], polygon[2]}, K, 1.0, out);
    } else if (polygon.size() == 4) {
        quad_points({polygon[0], polygon[1], polygon[2], polygon[3]}, K, 1.0, out);
    } else {
        const double A = area(polygon);
        const auto tris = triangulate(polygon);
        if (tris.size() <= static_cast<std::size_t>(K)) {
            for (const auto& t : tris) {
                const Vec3& a = polygon[static_cast<std::size_t>(t[0])];
                const Vec3& b = polygon[static_cast<std::size_t>(t[1])];
                const Vec3& c = polygon[static_cast<std::size_t>(t[2])];
                const double At = 0.5 * (b - a).cross(c - a).norm();
                const int k = std::max(1, static_cast<int>(std::lround(K * At / A)));
                quad_points({a, b, c, c}, k, At / A, out);
            }
        } else {
            bisection_points(polygon, K, A, out);
        }
    }
    return out;
}

Frame make_frame(const Vec3& point, const Vec3& normal, double rotation) {
    Frame f;
    f.origin = point;
    f.w = normal.normalized();
    Vec3 u, v;
    orthonormal_basis(f.w, u, v);
    const double c = std::cos(rotation), s = std::sin(rotation);
    f.u = c * u + s * v;
    f.v = -s * u + c * v;
    return f;
}

int clip_convex(const P3* in, int n, const ClipPlane& plane, P3* out) {
    int m = 0;
    for (int k = 0; k < n; ++k) {
        const P3& p = in[k];
        const P3& q = in[(k + 1) % n];
        const double dp = plane.distance(p);
        const double dq = plane.distance(q);
        const bool pin = dp >= 0.0, qin = dq >= 0.0;
        if (pin) out[m++] = p;
        if (pin != qin) {
            // From the inside end, so that a shared edge clips identically in both polygons.
            const P3& i = pin ? p : q;
            const P3& o = pin ? q : p;
            const double di = pin ? dp : dq;
            const double dout = pin ? dq : dp;
            const double t = di / (di - dout);
            out[m++] = {{i.v[0] + t * (o.v[0] - i.v[0]), i.v[1] + t * (o.v[1] - i.v[1]),
                         i.v[2] + t * (o.v[2] - i.v[2])}};
        }
    }
    return m;
}

void check_projection_options(int resolution, int points, bool power_of_two) {
    if (resolution < 64 || resolution > 2048) {
        throw OptionError("resolution",
                          "must be from 64 to 2048, got " + std::to_string(resolution));
    }
    if (power_of_two) {
        if ((resolution & (resolution - 1)) != 0) {
            throw OptionError("resolution",
                              "the hemiplane needs a power of two (64, 128, ..., "
                              "2048), got " +
                                  std::to_string(resolution));
        }
    } else if (resolution % 2 != 0) {
        throw OptionError("resolution",
                          "the hemicube needs an even value, got " + std::to_string(resolution));
    }
    if (points < 1 || points > 4096) {
        throw OptionError("points", "must be from 1 to 4096, got " + std::to_string(points));
    }
}

Frame point_frame(const char* method, const Vec3& point, const Vec3& normal, double rotation) {
    if (!(normal.norm() > 0.0) || !point.allFinite() || !normal.allFinite()) {
        throw GeometryError(std::string(method) +
                            ": the point and its normal must be finite, the normal "
                            "non-zero");
    }
    return make_frame(point, normal, rotation);
}

Vec3 patch_normal(const Patch& p) {
    return p.normal.squaredNorm() > 0.0 ? p.normal.normalized() : normal(p.polygon);
}

void check_patch_normals(const Scene& scene, const char* method) {
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        const Patch& p = scene.patches[i];
        if (p.polygon.size() < 3 || !(patch_normal(p).squaredNorm() > 0.0)) {
            throw GeometryError(std::string(method) + ": patch " + std::to_string(i) +
                                " is degenerate (no normal)");
        }
    }
}

FormFactors zero_form_factors(const Scene& scene, RowRange rows) {
    const std::size_t n = scene.patches.size();
    FormFactors out;
    out.first_row = rows.begin;
    out.F = DenseMatrix::Zero(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(n));
    out.areas.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Patch& p = scene.patches[i];
        out.areas[i] = p.area > 0.0 ? p.area : area(p.polygon);
    }
    return out;
}

}  // namespace formfactor::projection
