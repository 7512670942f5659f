// Points on a polygon distributed by the projected solid angle it subtends from a point
// (ProjectedPolygonSampler). Uniform points on a polygon are sampling.cpp.

#include <algorithm>
#include <bit>
#include <cmath>

#include "core/fast_atan.h"
#include "formfactor/core/error.h"
#include "formfactor/core/random.h"
#include "formfactor/geometry/sampling.h"
#include "geometry/cdf.h"

namespace formfactor {
namespace {

// A stand-in for atan2(y, x) that is monotone in the polar angle on (−π, π] (values in
// (−2, 2]): enough to order directions and to compare them, without a transcendental call.
double pseudo_angle(double x, double y) {
    const double s = std::abs(x) + std::abs(y);
    if (!(s > 0)) return 0.0;
    const double p = 1.0 - x / s;
    return y >= 0 ? p : -p;
}

}  // namespace

using detail::find_cell;

using detail::atan2_upper;

void ProjectedPolygonSampler::Arc::set(const Vec3& m, const Vec2& d0, const Vec2& d1,
                                       double cross) {
    half_mz = 0.5 * std::abs(m.z());
    mz2 = m.z() * m.z();
    mx = m.x();
    my = m.y();
    const double k0 = mx * d0.x() + my * d0.y(), k1 = mx * d1.x() + my * d1.y();
    S = std::abs(m.z()) * cross;
    C0 = mz2 + k0 * k0;
    C1 = mz2 * d0.dot(d1) + k0 * k1;
    if (!(C0 > 0)) {  // a vertical great circle through d0: the arc is a radius, no area
        half_mz = 0;
        C0 = 1;
    }
}

inline double ProjectedPolygonSampler::Arc::area(double t) const {
    return half_mz * atan2_upper(t * S, (1 - t) * C0 + t * C1);
}

inline void ProjectedPolygonSampler::Arc::slopes(double t, double& d1, double& d2) const {
    const double x = (1 - t) * C0 + t * C1, y = t * S, dx = C1 - C0;
    const double q = x * x + y * y;
    d1 = half_mz * S * C0 / q;
    d2 = -d1 * 2 * (x * dx + y * S) / q;
}

inline double ProjectedPolygonSampler::Arc::r2(const Vec2& v) const {
    const double a = mz2 * v.squaredNorm(), b = mx * v.x() + my * v.y();
    return a > 0 ? a / (a + b * b) : 0.0;
}

ProjectedPolygonSampler::ProjectedPolygonSampler(const Polygon& target) { reset(target); }

void ProjectedPolygonSampler::reset(const Polygon& target) {
    FF_ASSERT(target.size() >= 3);
    reset(target, normal(target), centroid(target), is_convex(target));
}

void ProjectedPolygonSampler::reset(const Polygon& target, const Vec3& unit_normal,
                                    const Vec3& point, bool convex) {
    FF_ASSERT(target.size() >= 3);
    target_normal_ = unit_normal;
    target_point_ = point;
    clear_origin();
    piece_count_ = 0;
    auto next_piece = [&]() -> std::vector<Vec3>& {
        if (pieces_.size() <= piece_count_) pieces_.emplace_back();
        std::vector<Vec3>& piece = pieces_[piece_count_++];
        piece.clear();
        return piece;
    };
    if (convex) {
        next_piece() = target.vertices;
    } else {
        for (const auto& t : triangulate(target)) {
            std::vector<Vec3>& piece = next_piece();
            for (int k : t) piece.push_back(target[static_cast<std::size_t>(k)]);
        }
    }
}

void ProjectedPolygonSampler::clear_origin() {
    cells_.clear();
    cdf_.clear();
    cells_ready_ = false;
    reject_ready_ = false;
    unit_count_ = 0;
    total_ = 0.0;
}

double ProjectedPolygonSampler::set_origin(const Vec3& x, const Vec3& n) {
    clear_origin();
    if (!(target_normal_.dot(x - target_point_) > 0)) return 0.0;
    if (n != n_) {
        n_ = n;
        orthonormal_basis(n_, t_, b_);
    }
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
        if (unit_pieces_.size() <= unit_count_) unit_pieces_.emplace_back();
        std::vector<Vec3>& unit = unit_pieces_[unit_count_];
        unit.clear();
        for (const Vec3& p : local_) {
            const double len = p.norm();
            if (!(len > 0)) continue;
            const Vec3 u = p / len;
            if (!unit.empty() && (u - unit.back()).squaredNorm() < 1e-28) continue;
            unit.push_back(u);
        }
        while (unit.size() > 1 && (unit.front() - unit.back()).squaredNorm() < 1e-28)
            unit.pop_back();
        if (unit.size() >= 3) ++unit_count_;
    }
    if (unit_count_ == 1 && prepare_rejection(unit_pieces_[0])) return form_factor();
    build_cells();
    total_ = cell_total_;
    return form_factor();
}

void ProjectedPolygonSampler::build_cells() {
    cells_.clear();
    cdf_.clear();
    for (std::size_t pc = 0; pc < unit_count_; ++pc) {
        scratch_ = unit_pieces_[pc];
        add_piece(scratch_);
    }
    double acc = 0.0;
    for (const Cell& c : cells_) {
        acc += c.area;
        cdf_.push_back(acc);
    }
    cell_total_ = acc;
    cells_ready_ = true;
}

bool ProjectedPolygonSampler::prepare_rejection(std::vector<Vec3>& l) {
    const std::size_t k = l.size();
    if (k > kMaxRejectionVertices) return false;
    double orient = 0.0;
    for (std::size_t a = 1; a + 1 < k; ++a) orient += l[0].dot(l[a].cross(l[a + 1]));
    if (orient == 0) return false;
    if (orient < 0) std::reverse(l.begin(), l.end());
    // Zenith inside (the sector fan is closed-form and cheap): no rejection. Same test as
    // add_piece().
    bool zenith_inside = true;
    for (std::size_t a = 0; a < k && zenith_inside; ++a)
        if (l[a].cross(l[(a + 1) % k]).z() < -1e-15) zenith_inside = false;
    if (zenith_inside) return false;
    // Lambert: the projected area is Σ ½ γ_k m_z over the edges (m the unit normal of the
    // edge's great circle, γ its angle); edge_cross_ keeps u_k × u_{k+1} for the inside test.
    double area = 0.0;
    edge_cross_.resize(k);
    for (std::size_t a = 0; a < k; ++a) {
        const Vec3& p = l[a];
        const Vec3& q = l[(a + 1) % k];
        const Vec3 c = p.cross(q);
        const double len = c.norm();
        if (!(len > 0)) return false;
        area += 0.5 * atan2_upper(len, p.dot(q)) * c.z() / len;
        edge_cross_[a] = c;
    }
    if (!(area > 0)) return false;
    // The proposal Q: the projected vertices, with each far arc (an edge running counter-
    // clockwise about the zenith, m_z > 0, bulging outwards) replaced by its tangent triangle's
    // apex; near arcs bulge into R, so their chords stay outside R. Q ⊇ R.
    proposal_.clear();
    for (std::size_t a = 0; a < k; ++a) {
        const Vec3& p = l[a];
        const Vec3& q = l[(a + 1) % k];
        const Vec2 P(p.x(), p.y());
        proposal_.push_back(P);
        // An edge whose great circle passes (within rounding) through the zenith projects onto
        // a radial segment: its chord is the arc (a vertical edge seen from below, say).
        const Vec3& c = edge_cross_[a];
        if (!(c.z() > 1e-12 * c.norm())) continue;
        const Vec3 tp = c.cross(p), tq = c.cross(q);  // tangents, in the direction of travel
        const Vec2 dp(tp.x(), tp.y()), dq(tq.x(), tq.y());
        const Vec2 Q(q.x(), q.y());
        const double den = dp.x() * dq.y() - dp.y() * dq.x();
        const Vec2 chord = Q - P;
        const double s = (chord.x() * dq.y() - chord.y() * dq.x()) / den;
        if (!(s > 0) || !std::isfinite(s)) return false;
        const Vec2 apex = P + s * dp;
        const Vec2 out = apex - P;
        if (chord.x() * out.y() - chord.y() * out.x() > 0) return false;  // not outside
        proposal_.push_back(apex);
    }
    // Fan from the mean vertex: Q must be star-shaped about it (every triangle positive).
    Vec2 centre = Vec2::Zero();
    for (std::size_t a = 0; a < k; ++a) centre += Vec2(l[a].x(), l[a].y());
    centre /= static_cast<double>(k);
    proposal_centre_ = centre;
    proposal_cdf_.clear();
    double acc = 0.0;
    const std::size_t m = proposal_.size();
    for (std::size_t t = 0; t < m; ++t) {
        const Vec2 e0 = proposal_[t] - centre, e1 = proposal_[(t + 1) % m] - centre;
        const double twice = e0.x() * e1.y() - e0.y() * e1.x();
        if (!(twice > 0)) return false;
        acc += 0.5 * twice;
        proposal_cdf_.push_back(acc);
    }
    if (area < kMinAcceptance * acc) return false;
    proposal_total_ = acc;
    unit_vertices_ = l.size();
    total_ = area;
    reject_ready_ = true;
    return true;
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
            const double gamma = atan2_upper(len, p.dot(q));
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
    // in (−π, π) without wrapping (a convex region off the zenith spans less than π); they are
    // ordered by pseudo-angles, and a wedge is bounded by the unit directions of its vertices.
    std::vector<Vec2>& dir = dir_;
    dir.resize(k);
    Vec2 ref = Vec2::Zero();
    for (std::size_t a = 0; a < k; ++a) {
        const double h = std::hypot(l[a].x(), l[a].y());
        dir[a] = h > 0 ? Vec2(l[a].x() / h, l[a].y() / h) : Vec2::Zero();
        ref += dir[a];
    }
    if (!(ref.norm() > 0)) return;
    ref.normalize();
    std::vector<double>& psi = psi_;
    psi.resize(k);
    edge_normal_.resize(k);
    for (std::size_t a = 0; a < k; ++a) {
        const double x = ref.x() * l[a].x() + ref.y() * l[a].y();
        const double y = ref.x() * l[a].y() - ref.y() * l[a].x();
        l[a] = Vec3(x, y, l[a].z());
        psi[a] = pseudo_angle(x, y);
        const Vec2 d = dir[a];
        dir[a] = d.isZero()
                     ? Vec2(1, 0)
                     : Vec2(ref.x() * d.x() + ref.y() * d.y(), ref.x() * d.y() - ref.y() * d.x());
    }
    // Unit normals of the edges' great circles (zero for a degenerate edge).
    for (std::size_t a = 0; a < k; ++a) {
        const Vec3 c = l[a].cross(l[(a + 1) % k]);
        const double len = c.norm();
        edge_normal_[a] = len > 0 ? Vec3(c / len) : Vec3::Zero();
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
    Vec2 dcur = dir[kmin];
    while (f + 1 < far.size() && m + 1 < near.size()) {
        const double nf = std::max(cur, psi[far[f + 1]]);
        const double nn = std::max(cur, psi[near[m + 1]]);
        const double next = std::min(nf, nn);
        if (next > cur) {
            const Vec2& dnext = nf <= nn ? dir[far[f + 1]] : dir[near[m + 1]];
            // The far chain runs forwards (edge far[f] → far[f + 1] is edge far[f]), the near
            // chain backwards (edge near[m + 1] → near[m]).
            const Vec3& mf = edge_normal_[far[f]];
            const Vec3& mn = edge_normal_[near[m + 1]];
            const double cross = dcur.x() * dnext.y() - dcur.y() * dnext.x();
            if (!mf.isZero() && !mn.isZero() && cross > 0) {
                Cell cell{};
                cell.fan = false;
                cell.d0 = dcur;
                cell.d1 = dnext;
                cell.rc = ref.x();
                cell.rs = ref.y();
                cell.far.set(mf, dcur, dnext, cross);
                cell.near.set(mn, dcur, dnext, cross);
                cell.area = cell.far.area(1.0) - cell.near.area(1.0);
                if (cell.area > 0) cells_.push_back(cell);
            }
            dcur = dnext;
        }
        cur = next;
        if (nf <= next) ++f;
        if (nn <= next) ++m;
    }
}

double ProjectedPolygonSampler::sample_wedge(const Cell& c, double s) const {
    // Invert A(t) = far.area(t) − near.area(t) = s on [0, 1]. A start from a quadratic model
    // (end slopes; it copes with a wedge that closes at an end, A' = 0 there), polished by
    // Newton steps on the Hermite cubic of A (no transcendental calls), then Halley steps on A
    // itself (two atan2 each; A' and A'' are rational) with a bisection safeguard.
    double f1 = 0, f2 = 0, n1 = 0, n2 = 0;
    c.far.slopes(0.0, f1, f2);
    c.near.slopes(0.0, n1, n2);
    const double a0 = std::max(0.0, f1 - n1);  // 0 (up to rounding) where the wedge closes
    c.far.slopes(1.0, f1, f2);
    c.near.slopes(1.0, n1, n2);
    const double a1 = std::max(0.0, f1 - n1);
    const double area = c.area;
    const double t_lin = std::clamp(s / area, 0.0, 1.0);
    double t = t_lin;
    const double sum = 0.5 * (a0 + a1);
    if (sum > 0) {
        // A(t) ≈ a0 t + (a1 − a0) t²/2, rescaled so that A(1) = area.
        const double qa = 0.5 * (a1 - a0) / sum, qb = a0 / sum;  // qa t² + qb t = t_lin
        double tq = t_lin;
        if (std::abs(qa) > 1e-12) {
            const double disc = qb * qb + 4 * qa * t_lin;
            if (disc >= 0) tq = 2 * t_lin / (qb + std::sqrt(disc));
        } else if (qb > 0) {
            tq = t_lin / qb;
        }
        if (tq >= 0 && tq <= 1) t = tq;
        // Hermite cubic M(t) = a0 t + c2 t² + c3 t³ with M(1) = area, M'(1) = a1.
        const double c2 = 3 * area - 2 * a0 - a1, c3 = a0 + a1 - 2 * area;
        for (int k = 0; k < 3; ++k) {
            const double m = ((c3 * t + c2) * t + a0) * t - s;
            const double dm = (3 * c3 * t + 2 * c2) * t + a0;
            if (!(dm > 0)) break;
            const double nt = t - m / dm;
            if (!(nt >= 0 && nt <= 1)) break;
            t = nt;
        }
    }
    double lo = 0.0, hi = 1.0;
    // A Halley step of at most kHalleyStop leaves an error of order its cube; other steps
    // (bisections) stop at kTol. Directions then match a solve to full precision to ~1e-8
    // (measured on the Cornell box's pairs).
    constexpr double kHalleyStop = 1e-6, kTol = 1e-12;
    for (int it = 0; it < 64; ++it) {
        const double g = c.far.area(t) - c.near.area(t) - s;
        if (g > 0)
            hi = t;
        else
            lo = t;
        c.far.slopes(t, f1, f2);
        c.near.slopes(t, n1, n2);
        const double d1 = f1 - n1, d2 = f2 - n2;
        const double den = 2 * d1 * d1 - g * d2;
        double next = d1 > 0 && den > 0 ? t - 2 * g * d1 / den : 0.5 * (lo + hi);
        const bool halley = next > lo && next < hi;
        if (!halley) next = 0.5 * (lo + hi);
        const double step = std::abs(next - t);
        if ((halley && step <= kHalleyStop) || step <= kTol || hi - lo <= kTol) return next;
        t = next;
    }
    return t;
}

Vec3 ProjectedPolygonSampler::sample(double u, double v) {
    if (!cells_ready_) build_cells();
    if (cells_.empty() && reject_ready_) {  // degenerate wedges: rejection, seeded by (u, v)
        std::uint64_t rng = splitmix64(std::bit_cast<std::uint64_t>(u) ^
                                       splitmix64(std::bit_cast<std::uint64_t>(v)));
        return sample(u, v, rng);
    }
    FF_ASSERT(!cells_.empty());
    const double s = u * cell_total_;
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
        const double t = sample_wedge(c, s_in);
        const Vec2 dir = (1 - t) * c.d0 + t * c.d1;
        const double rf2 = c.far.r2(dir), rn2 = c.near.r2(dir);
        const double r2 = std::clamp(rn2 + v * (rf2 - rn2), 0.0, 1.0);
        const double scale = std::sqrt(r2) / dir.norm();
        const double x = scale * dir.x(), y = scale * dir.y();
        // Undo the wedge frame's rotation.
        d = Vec3(c.rc * x - c.rs * y, c.rs * x + c.rc * y, std::sqrt(1.0 - r2));
    }
    return d.x() * t_ + d.y() * b_ + d.z() * n_;
}

Vec3 ProjectedPolygonSampler::sample(double u, double v, std::uint64_t& rng) {
    if (!reject_ready_) return sample(u, v);
    // Uniform points of the proposal Q (a triangle picked by area with u, rescaled; Heitz's
    // square-to-triangle map), kept when they lie in R: lifted to the hemisphere, inside every
    // edge's great-circle half-space. Exactly uniform on R, hence exactly cosine-distributed
    // over the target's solid angle. The first candidate comes from (u, v), others from rng.
    const std::size_t m = proposal_.size();
    for (int attempt = 0; attempt < 1000; ++attempt) {
        if (attempt > 0) {
            u = to_unit(splitmix64(rng++));
            v = to_unit(splitmix64(rng++));
        }
        const double s = u * proposal_total_;
        const std::size_t t = find_cell(proposal_cdf_, s);
        const double lo = t == 0 ? 0.0 : proposal_cdf_[t - 1];
        const double a = std::clamp((s - lo) / (proposal_cdf_[t] - lo), 0.0, 1.0);
        double b0 = a, b1 = v;
        detail::square_to_triangle(b0, b1);
        const Vec2 q =
            b0 * proposal_centre_ + b1 * proposal_[t] + (1.0 - b0 - b1) * proposal_[(t + 1) % m];
        const double r2 = q.squaredNorm();
        if (!(r2 < 1.0)) continue;
        const Vec3 p(q.x(), q.y(), std::sqrt(1.0 - r2));
        bool inside = true;
        for (std::size_t e = 0; e < unit_vertices_ && inside; ++e)
            inside = edge_cross_[e].dot(p) >= 0.0;
        if (inside) return p.x() * t_ + p.y() * b_ + p.z() * n_;
    }
    return sample(u, v);  // not reached unless R is a sliver of Q
}

}  // namespace formfactor
