#include "formfactor/geometry/sampling.h"

#include <algorithm>
#include <cmath>

#include "formfactor/core/error.h"

namespace formfactor {
namespace {

// Difference of two E values of one arc, unwrapped: a wedge spans less than π, and so does
// E across it.
double unwrap(double d) {
    if (d > kPi) return d - 2 * kPi;
    if (d < -kPi) return d + 2 * kPi;
    return d;
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

void ProjectedPolygonSampler::Arc::set(const Vec3& m) {
    a = std::abs(m.z());
    rho = std::hypot(m.x(), m.y());
    if (rho > 0) {
        cb = m.x() / rho;
        sb = m.y() / rho;
    } else {
        cb = 1;
        sb = 0;
    }
}

double ProjectedPolygonSampler::Arc::E(double c, double s) const {
    const double ct = c * cb + s * sb, st = s * cb - c * sb;  // cos θ, sin θ
    return std::atan2(a * st, ct);
}

double ProjectedPolygonSampler::Arc::r2(double c, double s) const {
    const double ct = c * cb + s * sb;
    const double den = a * a + rho * rho * ct * ct;
    return den > 0 ? a * a / den : 0.0;
}

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

// ---- projected-solid-angle sampling of a polygon ----

ProjectedPolygonSampler::ProjectedPolygonSampler(const Polygon& target) { reset(target); }

void ProjectedPolygonSampler::reset(const Polygon& target) {
    FF_ASSERT(target.size() >= 3);
    target_normal_ = normal(target);
    target_point_ = centroid(target);
    cells_.clear();
    cdf_.clear();
    total_ = 0.0;
    piece_count_ = 0;
    auto next_piece = [&]() -> std::vector<Vec3>& {
        if (pieces_.size() <= piece_count_) pieces_.emplace_back();
        std::vector<Vec3>& piece = pieces_[piece_count_++];
        piece.clear();
        return piece;
    };
    if (is_convex(target)) {
        next_piece() = target.vertices;
    } else {
        for (const auto& t : triangulate(target)) {
            std::vector<Vec3>& piece = next_piece();
            for (int k : t) piece.push_back(target[static_cast<std::size_t>(k)]);
        }
    }
}

double ProjectedPolygonSampler::set_origin(const Vec3& x, const Vec3& n) {
    cells_.clear();
    cdf_.clear();
    total_ = 0.0;
    if (!(target_normal_.dot(x - target_point_) > 0)) return 0.0;
    n_ = n;
    orthonormal_basis(n_, t_, b_);
    for (std::size_t pc = 0; pc < piece_count_; ++pc) {
        // Local coordinates (t, b, n) about x, clipped to z ≥ 0 (Sutherland–Hodgman).
        scratch_.clear();
        bool all_above = true;
        for (const Vec3& y : pieces_[pc]) {
            const Vec3 d = y - x;
            scratch_.emplace_back(d.dot(t_), d.dot(b_), d.dot(n_));
            all_above = all_above && scratch_.back().z() > 0;
        }
        local_.clear();
        const std::size_t k = scratch_.size();
        if (all_above) local_.swap(scratch_);
        for (std::size_t a = 0; a < k && !all_above; ++a) {
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

void ProjectedPolygonSampler::add_piece(std::vector<Vec3>& l) {
    const std::size_t k = l.size();
    // Orientation: a convex spherical polygon in the upper hemisphere is counter-clockwise seen
    // from above (positive projected area) when its fan's triple products are positive.
    double orient = 0.0;
    for (std::size_t a = 1; a + 1 < k; ++a) orient += l[0].dot(l[a].cross(l[a + 1]));
    if (orient < 0) std::reverse(l.begin(), l.end());
    if (orient == 0) return;

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
    std::vector<double>& psi = psi_;
    psi.resize(k);
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
    std::vector<std::size_t>& far = far_;
    std::vector<std::size_t>& near = near_;
    far.assign(1, kmin);
    near.assign(1, kmin);
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
                cell.far.set(cf.normalized());
                cell.near.set(cn.normalized());
                const double c0 = std::cos(cur), s0 = std::sin(cur);
                const double c1 = std::cos(next), s1 = std::sin(next);
                cell.c0 = c0;
                cell.s0 = s0;
                cell.c1 = c1;
                cell.s1 = s1;
                cell.far.e0 = cell.far.E(c0, s0);
                cell.near.e0 = cell.near.E(c0, s0);
                cell.area = 0.5 * cell.far.a * unwrap(cell.far.E(c1, s1) - cell.far.e0) -
                            0.5 * cell.near.a * unwrap(cell.near.E(c1, s1) - cell.near.e0);
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
    // Invert A(φ) = ½a_f ΔE_f(φ) − ½a_n ΔE_n(φ) = s on [φ0, φ1]: Newton from a quadratic model
    // built from the end slopes A'(φ) = ½(r_f² − r_n²), with a bisection safeguard. Wedges are
    // narrow, so two or three steps reach the tolerance (1e-12 of the wedge's width).
    double lo = c.phi0, hi = c.phi1;
    const double width = hi - lo;
    const double t_lin = std::clamp(s / c.area, 0.0, 1.0);
    double phi = lo + width * t_lin;
    {
        const double c0 = c.c0, s0 = c.s0, c1 = c.c1, s1 = c.s1;
        const double d0 = 0.5 * (c.far.r2(c0, s0) - c.near.r2(c0, s0)) * width;
        const double d1 = 0.5 * (c.far.r2(c1, s1) - c.near.r2(c1, s1)) * width;
        // A(t) ≈ d0 t + (d1 − d0) t²/2, rescaled so that A(1) = area.
        const double sum = 0.5 * (d0 + d1);
        if (sum > 0 && d0 >= 0 && d1 >= 0) {
            const double qa = 0.5 * (d1 - d0) / sum, qb = d0 / sum;  // qa t² + qb t = t_lin
            double t = t_lin;
            if (std::abs(qa) > 1e-12) {
                const double disc = qb * qb + 4 * qa * t_lin;
                if (disc >= 0) t = 2 * t_lin / (qb + std::sqrt(disc));
            } else if (qb > 0) {
                t = t_lin / qb;
            }
            if (t >= 0 && t <= 1) phi = lo + width * t;
        }
    }
    const double tol = 1e-12 * width + 1e-15;
    for (int it = 0; it < 64; ++it) {
        const double cp = std::cos(phi), sp = std::sin(phi);
        const double g = 0.5 * c.far.a * unwrap(c.far.E(cp, sp) - c.far.e0) -
                         0.5 * c.near.a * unwrap(c.near.E(cp, sp) - c.near.e0) - s;
        if (g > 0)
            hi = phi;
        else
            lo = phi;
        const double dg = 0.5 * (c.far.r2(cp, sp) - c.near.r2(cp, sp));
        double next = dg > 0 ? phi - g / dg : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (std::abs(next - phi) <= tol || hi - lo <= tol) return next;
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
        const double cp = std::cos(phi), sp = std::sin(phi);
        const double rf2 = c.far.r2(cp, sp), rn2 = c.near.r2(cp, sp);
        const double r2 = std::clamp(rn2 + v * (rf2 - rn2), 0.0, 1.0);
        const double r = std::sqrt(r2);
        const double x = r * cp, y = r * sp;
        // Undo the wedge frame's rotation.
        d = Vec3(c.a.x() * x + c.b.x() * y, c.a.y() * x + c.b.y() * y, std::sqrt(1.0 - r2));
    }
    return d.x() * t_ + d.y() * b_ + d.z() * n_;
}

}  // namespace formfactor
