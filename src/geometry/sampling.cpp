#include "formfactor/geometry/sampling.h"

#include <algorithm>
#include <cmath>

#include "formfactor/core/error.h"

namespace formfactor {
namespace {

double angle_between(const Vec3& a, const Vec3& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

// The point of the great circle with unit normal m whose horizontal direction has polar angle
// phi (in the local frame, z up): the circle meets the meridian half-plane at phi there.
Vec3 point_on_circle(const Vec3& m, double phi) {
    const double c = std::cos(phi), s = std::sin(phi);
    Vec3 v = m.cross(Vec3(-s, c, 0.0));
    if (v.x() * c + v.y() * s < 0) v = -v;
    const double len = v.norm();
    return len > 0 ? Vec3(v / len) : Vec3(c, s, 0.0);
}

// Index of the cell whose cumulative range holds s (cdf ascending, last = total).
std::size_t find_cell(const std::vector<double>& cdf, double s) {
    if (cdf.size() <= 8) {
        std::size_t k = 0;
        while (k + 1 < cdf.size() && s >= cdf[k]) ++k;
        return k;
    }
    auto it = std::upper_bound(cdf.begin(), cdf.end(), s);
    return std::min<std::size_t>(static_cast<std::size_t>(it - cdf.begin()), cdf.size() - 1);
}

}  // namespace

bool is_convex(const Polygon& p) {
    const Vec3 n = normal(p);
    const std::size_t k = p.size();
    if (k < 3) return false;
    const double scale = diameter(p);
    for (std::size_t a = 0; a < k; ++a) {
        const Vec3& p0 = p[a];
        const Vec3& p1 = p[(a + 1) % k];
        const Vec3& p2 = p[(a + 2) % k];
        if ((p1 - p0).cross(p2 - p1).dot(n) < -1e-12 * scale * scale) return false;
    }
    return true;
}

// ---- uniform points on a polygon ----

PolygonSampler::PolygonSampler(const Polygon& p) {
    FF_ASSERT(p.size() >= 3);
    const double scale = diameter(p);
    if (p.size() == 4 && (p[0] + p[2] - p[1] - p[3]).norm() <= 1e-12 * scale) {
        parallelogram_ = true;
        origin_ = p[0];
        e1_ = p[1] - p[0];
        e2_ = p[3] - p[0];
        return;
    }
    std::vector<std::array<int, 3>> tris;
    if (p.size() == 3)
        tris.push_back({0, 1, 2});
    else
        tris = triangulate(p);
    double total = 0.0;
    for (const auto& t : tris) {
        const std::array<Vec3, 3> tri{p[static_cast<std::size_t>(t[0])],
                                      p[static_cast<std::size_t>(t[1])],
                                      p[static_cast<std::size_t>(t[2])]};
        total += 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).norm();
        triangles_.push_back(tri);
        cdf_.push_back(total);
    }
    FF_ASSERT(total > 0);
    for (double& c : cdf_) c /= total;
    cdf_.back() = 1.0;
}

Vec3 PolygonSampler::operator()(double u, double v) const {
    if (parallelogram_) return origin_ + u * e1_ + v * e2_;
    std::size_t k = 0;
    if (triangles_.size() > 1) {
        k = find_cell(cdf_, u);
        const double lo = k == 0 ? 0.0 : cdf_[k - 1];
        u = std::clamp((u - lo) / (cdf_[k] - lo), 0.0, 1.0);
    }
    // Heitz 2019: low-distortion square → triangle.
    double b0 = u, b1 = v;
    if (b1 > b0) {
        b0 *= 0.5;
        b1 -= b0;
    } else {
        b1 *= 0.5;
        b0 -= b1;
    }
    const auto& t = triangles_[k];
    return b0 * t[0] + b1 * t[1] + (1.0 - b0 - b1) * t[2];
}

Vec3 cosine_direction(double u, double v) {
    const double a = 2.0 * u - 1.0, b = 2.0 * v - 1.0;
    // Branch-free selects: the octant is unpredictable for random or quasi-random input.
    const bool first = std::abs(a) > std::abs(b);
    const double r = first ? a : b;
    const double q = first ? b : a;
    const double t = r != 0.0 ? q / r : 0.0;
    const double phi = first ? 0.25 * kPi * t : 0.5 * kPi - 0.25 * kPi * t;
    // Single-precision sine and cosine: rays are traced in float anyway (~6e-8 relative).
    const float fphi = static_cast<float>(phi);
    const double x = r * static_cast<double>(std::cos(fphi));
    const double y = r * static_cast<double>(std::sin(fphi));
    return {x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
}

// ---- projected-solid-angle sampling of a polygon ----

ProjectedPolygonSampler::ProjectedPolygonSampler(const Polygon& target) {
    FF_ASSERT(target.size() >= 3);
    target_normal_ = normal(target);
    target_point_ = centroid(target);
    if (is_convex(target)) {
        pieces_.push_back(target.vertices);
    } else {
        for (const auto& t : triangulate(target))
            pieces_.push_back({target[static_cast<std::size_t>(t[0])],
                               target[static_cast<std::size_t>(t[1])],
                               target[static_cast<std::size_t>(t[2])]});
    }
}

double ProjectedPolygonSampler::set_origin(const Vec3& x, const Vec3& n) {
    cells_.clear();
    cdf_.clear();
    total_ = 0.0;
    if (!(target_normal_.dot(x - target_point_) > 0)) return 0.0;
    n_ = n;
    orthonormal_basis(n_, t_, b_);
    for (const auto& piece : pieces_) {
        // Local coordinates (t, b, n) about x, clipped to z ≥ 0 (Sutherland–Hodgman).
        scratch_.clear();
        for (const Vec3& y : piece) {
            const Vec3 d = y - x;
            scratch_.emplace_back(d.dot(t_), d.dot(b_), d.dot(n_));
        }
        local_.clear();
        const std::size_t k = scratch_.size();
        for (std::size_t a = 0; a < k; ++a) {
            const Vec3& p = scratch_[a];
            const Vec3& q = scratch_[(a + 1) % k];
            if (p.z() >= 0) local_.push_back(p);
            if ((p.z() >= 0) != (q.z() >= 0) && p.z() != q.z()) {
                const double s = p.z() / (p.z() - q.z());
                Vec3 c = p + s * (q - p);
                c.z() = 0.0;
                local_.push_back(c);
            }
        }
        // Onto the unit sphere; drop repeated directions.
        scratch_.clear();
        for (const Vec3& p : local_) {
            const double len = p.norm();
            if (!(len > 0)) continue;
            const Vec3 u = p / len;
            if (!scratch_.empty() && (u - scratch_.back()).norm() < 1e-14) continue;
            scratch_.push_back(u);
        }
        while (scratch_.size() > 1 && (scratch_.front() - scratch_.back()).norm() < 1e-14)
            scratch_.pop_back();
        if (scratch_.size() >= 3) add_piece(scratch_);
    }
    double acc = 0.0;
    for (const Cell& c : cells_) {
        acc += c.area;
        cdf_.push_back(acc);
    }
    total_ = acc;
    return form_factor();
}

void ProjectedPolygonSampler::add_piece(const std::vector<Vec3>& l0) {
    std::vector<Vec3> l = l0;
    const std::size_t k = l.size();
    auto signed_area = [&] {
        double s = 0.0;
        for (std::size_t a = 0; a < k; ++a) {
            const Vec3 c = l[a].cross(l[(a + 1) % k]);
            const double len = c.norm();
            if (len > 0) s += 0.5 * std::atan2(len, l[a].dot(l[(a + 1) % k])) * c.z() / len;
        }
        return s;
    };
    double area = signed_area();
    if (area < 0) {
        std::reverse(l.begin(), l.end());
        area = -area;
    }
    if (!(area > 1e-300)) return;

    bool zenith_inside = true;
    for (std::size_t a = 0; a < k && zenith_inside; ++a)
        if (l[a].cross(l[(a + 1) % k]).z() < -1e-15) zenith_inside = false;

    if (zenith_inside) {
        for (std::size_t a = 0; a < k; ++a) {
            const Vec3& p = l[a];
            const Vec3& q = l[(a + 1) % k];
            const Vec3 c = p.cross(q);
            const double len = c.norm();
            if (!(len > 0)) continue;
            const double gamma = std::atan2(len, p.dot(q));
            const double ar = 0.5 * gamma * c.z() / len;
            if (!(ar > 0)) continue;
            Cell cell{};
            cell.area = ar;
            cell.fan = true;
            cell.a = p;
            cell.b = (q - p.dot(q) * p).normalized();
            cell.gamma = gamma;
            cells_.push_back(cell);
        }
        return;
    }

    // Wedges. Rotate about z so that the mean horizontal direction is +x: polar angles then lie
    // in (−π, π] without wrapping (a convex region off the zenith spans less than π).
    Vec2 ref = Vec2::Zero();
    for (const Vec3& p : l) {
        const Vec2 h(p.x(), p.y());
        if (h.norm() > 0) ref += h / h.norm();
    }
    if (!(ref.norm() > 0)) return;
    ref.normalize();
    std::vector<double> psi(k);
    for (std::size_t a = 0; a < k; ++a) {
        const double x = ref.x() * l[a].x() + ref.y() * l[a].y();
        const double y = ref.x() * l[a].y() - ref.y() * l[a].x();
        l[a] = Vec3(x, y, l[a].z());
        psi[a] = std::atan2(y, x);
    }
    std::size_t kmin = 0, kmax = 0;
    for (std::size_t a = 1; a < k; ++a) {
        if (psi[a] < psi[kmin]) kmin = a;
        if (psi[a] > psi[kmax]) kmax = a;
    }
    // Far chain: kmin → kmax forwards (polar angle increasing on the CCW boundary); near chain:
    // kmin → kmax backwards.
    std::vector<std::size_t> far{kmin}, near{kmin};
    for (std::size_t a = kmin; a != kmax;) {
        a = (a + 1) % k;
        far.push_back(a);
    }
    for (std::size_t a = kmin; a != kmax;) {
        a = (a + k - 1) % k;
        near.push_back(a);
    }
    std::size_t f = 0, m = 0;
    double cur = psi[kmin];
    while (f + 1 < far.size() && m + 1 < near.size()) {
        const double nf = std::max(cur, psi[far[f + 1]]);
        const double nn = std::max(cur, psi[near[m + 1]]);
        const double next = std::min(nf, nn);
        if (next > cur) {
            const Vec3 cf = l[far[f]].cross(l[far[f + 1]]);
            const Vec3 cn = l[near[m]].cross(l[near[m + 1]]);
            if (cf.norm() > 0 && cn.norm() > 0) {
                Cell cell{};
                cell.fan = false;
                cell.phi0 = cur;
                cell.phi1 = next;
                cell.m_far = cf.normalized();
                cell.m_near = cn.normalized();
                cell.k_far = 0.5 * std::abs(cell.m_far.z());
                cell.k_near = 0.5 * std::abs(cell.m_near.z());
                cell.far0 = point_on_circle(cell.m_far, cur);
                cell.near0 = point_on_circle(cell.m_near, cur);
                const Vec3 far1 = point_on_circle(cell.m_far, next);
                const Vec3 near1 = point_on_circle(cell.m_near, next);
                cell.area = cell.k_far * angle_between(cell.far0, far1) -
                            cell.k_near * angle_between(cell.near0, near1);
                // The rotation back to the (t, b) frame rides in a and b.
                cell.a = Vec3(ref.x(), ref.y(), 0.0);
                cell.b = Vec3(-ref.y(), ref.x(), 0.0);
                if (cell.area > 0) cells_.push_back(cell);
            }
        }
        cur = next;
        if (nf <= next) ++f;
        if (nn <= next) ++m;
    }
}

double ProjectedPolygonSampler::sample_wedge_angle(const Cell& c, double s) const {
    double lo = c.phi0, hi = c.phi1;
    double phi = lo + (hi - lo) * std::clamp(s / c.area, 0.0, 1.0);
    for (int it = 0; it < 64; ++it) {
        const Vec3 vf = point_on_circle(c.m_far, phi);
        const Vec3 vn = point_on_circle(c.m_near, phi);
        const double g =
            c.k_far * angle_between(c.far0, vf) - c.k_near * angle_between(c.near0, vn) - s;
        if (g > 0)
            hi = phi;
        else
            lo = phi;
        const double dg = 0.5 * ((1 - vf.z() * vf.z()) - (1 - vn.z() * vn.z()));
        double next = dg > 0 ? phi - g / dg : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (std::abs(next - phi) <= 1e-14 * (1.0 + std::abs(phi)) || hi - lo <= 1e-15) return next;
        phi = next;
    }
    return phi;
}

Vec3 ProjectedPolygonSampler::sample(double u, double v) const {
    FF_ASSERT(!cells_.empty());
    const double s = u * total_;
    const std::size_t k = find_cell(cdf_, s);
    const Cell& c = cells_[k];
    const double s_in = std::clamp(s - (k == 0 ? 0.0 : cdf_[k - 1]), 0.0, c.area);
    Vec3 d;
    if (c.fan) {
        const double alpha = c.gamma * (s_in / c.area);
        const Vec3 p = std::cos(alpha) * c.a + std::sin(alpha) * c.b;
        const double rho = std::sqrt(v);
        const double x = rho * p.x(), y = rho * p.y();
        d = Vec3(x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y)));
    } else {
        const double phi = sample_wedge_angle(c, s_in);
        const Vec3 vf = point_on_circle(c.m_far, phi);
        const Vec3 vn = point_on_circle(c.m_near, phi);
        const double rf2 = 1.0 - vf.z() * vf.z(), rn2 = 1.0 - vn.z() * vn.z();
        const double r2 = std::clamp(rn2 + v * (rf2 - rn2), 0.0, 1.0);
        const double r = std::sqrt(r2);
        const double x = r * std::cos(phi), y = r * std::sin(phi);
        // Undo the wedge frame's rotation.
        d = Vec3(c.a.x() * x + c.b.x() * y, c.a.y() * x + c.b.y() * y, std::sqrt(1.0 - r2));
    }
    return d.x() * t_ + d.y() * b_ + d.z() * n_;
}

}  // namespace formfactor
