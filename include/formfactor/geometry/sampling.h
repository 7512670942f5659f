#pragma once
/// Sampling points and directions for the Monte-Carlo methods: uniform points on a polygon,
/// cosine-weighted directions, and directions distributed by the projected solid angle of a
/// polygon (the Nusselt analogue). Each maps numbers in [0,1)² so that stratified and
/// low-discrepancy points keep their structure.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor {

/// Uniform points on a polygon (by area). Parallelograms use the affine map of the unit square;
/// other polygons pick a triangle of an ear-clipping triangulation by area (first coordinate,
/// rescaled) and map into it with Heitz's low-distortion square-to-triangle map ("A Low-
/// Distortion Map Between Triangle and Square", 2019).
class PolygonSampler {
  public:
    PolygonSampler() = default;
    explicit PolygonSampler(const Polygon& p);
    /// A point of the polygon; uniform on its area when (u, v) is uniform on [0,1)².
    Vec3 operator()(double u, double v) const;

  private:
    bool parallelogram_ = false;
    Vec3 origin_ = Vec3::Zero(), e1_ = Vec3::Zero(), e2_ = Vec3::Zero();
    std::vector<std::array<Vec3, 3>> triangles_;
    std::vector<double> cdf_;  // cumulative area fractions, last = 1
};

/// Cosine-weighted direction about +z (pdf cosθ/π): Shirley–Chiu concentric map of the unit
/// square onto the disk, lifted to the hemisphere (Malley's method). Inline and branch-free so
/// that batch loops vectorise: the sine and cosine of the map's angle (|α| ≤ π/4) are Taylor
/// polynomials of degree 11 and 12 (error < 1e-11).
inline Vec3 cosine_direction(double u, double v) {
    const double a = 2.0 * u - 1.0, b = 2.0 * v - 1.0;
    // The octant is unpredictable for random or quasi-random input: selects, not branches.
    const bool first = std::abs(a) > std::abs(b);
    const double r = first ? a : b;
    const double q = first ? b : a;
    const double t = r != 0.0 ? q / r : 0.0;
    // φ = α (first) or π/2 − α, α = π/4·t ∈ [−π/4, π/4].
    const double al = 0.25 * kPi * t, a2 = al * al;
    const double s =
        al * (1.0 + a2 * (-1.0 / 6 +
                          a2 * (1.0 / 120 + a2 * (-1.0 / 5040 +
                                                  a2 * (1.0 / 362880 + a2 * (-1.0 / 39916800))))));
    const double c =
        1.0 + a2 * (-0.5 + a2 * (1.0 / 24 +
                                 a2 * (-1.0 / 720 + a2 * (1.0 / 40320 + a2 * (-1.0 / 3628800 +
                                                                              a2 / 479001600.0)))));
    const double x = r * (first ? c : s);
    const double y = r * (first ? s : c);
    return {x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
}

/// Directions from a point x (unit normal n) towards a polygon with probability density
/// proportional to cosθ over the polygon's solid angle: every direction carries the same
/// weight F_{dA→A} (the unoccluded point-to-polygon form factor). Used by mc-target.
///
/// Scheme (the Nusselt analogue, exact, no rejection): the polygon, clipped to the half-space in
/// front of x, is projected onto the unit hemisphere and then orthographically onto the base
/// disk; cosine-weighted directions are uniform points in that projected region R, whose area is
/// π F_{dA→A}. Each polygon edge becomes an arc of an ellipse centred at the disk's centre (the
/// projection of a great circle). Convex pieces of the polygon are handled one at a time:
///  - zenith inside the piece: R is the union of the elliptic sectors (centre, edge arc); each
///    is the linear image of a circular sector of its great-circle disk, so a uniform point is
///    closed-form (angle uniform along the arc, radius √u);
///  - zenith outside: the rays from the centre through the projected vertices cut R into wedges
///    bounded by one far and one near arc; the polar angle is drawn by inverting the wedge's
///    area function (sector areas are ½|m_z|·arc angle; Newton with bisection safeguard), and
///    the radius with r² uniform between the near and far arcs.
/// The piece (sector or wedge) is chosen by area with the first coordinate, rescaled.
/// Non-convex polygons are split into triangles (ear clipping) first. Cf. Arvo, "Stratified
/// sampling of spherical triangles", SIGGRAPH 1995 (solid angle), and Peters, "BRDF importance
/// sampling for polygonal lights", SIGGRAPH 2021 (projected solid angle).
class ProjectedPolygonSampler {
  public:
    ProjectedPolygonSampler() = default;
    /// Prepares for `target`, a planar polygon whose front (normal) side receives.
    explicit ProjectedPolygonSampler(const Polygon& target);
    /// Prepares for another target, reusing the memory (no allocation once warm).
    void reset(const Polygon& target);
    /// Same, given the target's unit normal, a point of its plane and whether it is convex
    /// (is_convex), when the caller has them.
    void reset(const Polygon& target, const Vec3& unit_normal, const Vec3& point, bool convex);

    /// Sets the sending point x with unit normal n. Returns F_{dA→A}, the unoccluded form
    /// factor from x to the front of the polygon (0 when x does not see the front; then
    /// sample() must not be called).
    double set_origin(const Vec3& x, const Vec3& n);
    /// A unit direction (world coordinates) from x into the polygon's solid angle, density
    /// cosθ / (π F_{dA→A}) when (u, v) is uniform on [0,1)²: the inverse of the cells'
    /// cumulative area (measure-preserving, so stratified (u, v) stay stratified). Builds the
    /// cells on its first call after set_origin() when sample(u, v, rng) did not need them.
    Vec3 sample(double u, double v);
    /// A direction with the same density, cheaper: by rejection from a polygon Q around the
    /// projected region R (Q: the projected vertices and the apexes of the far arcs' tangent
    /// triangles) when set_origin() found one with area(R) ≥ kMinAcceptance·area(Q) (a target
    /// that is one convex piece after clipping by the sender's plane, zenith outside it), else
    /// sample(u, v). The first candidate comes from (u, v), further ones from SplitMix64 of
    /// the counter `rng` (advanced), so the result is a pure function of (u, v, rng).
    Vec3 sample(double u, double v, std::uint64_t& rng);
    /// True when the last set_origin() prepared the rejection sampler.
    bool uses_rejection() const { return reject_ready_; }
    /// Smallest acceptance area(R)/area(Q) for which sample(u, v, rng) uses rejection.
    static constexpr double kMinAcceptance = 0.5;
    /// F_{dA→A} of the last set_origin().
    double form_factor() const { return total_ * kInvPi; }

  private:
    /// A projected great-circle arc (unit normal m) inside a wedge whose polar directions run
    /// along v(t) = (1−t)·d0 + t·d1, t ∈ [0, 1]. The great circle meets the vertical plane
    /// through v(t) at P(t) = (−m_z v(t), m_xy·v(t)), linear in t, so the arc angle from P(0)
    /// is γ(t) = atan2(t·S, (1−t)·C0 + t·C1) (S = |P(0) × P(1)|, C0 = |P(0)|², C1 = P(0)·P(1)),
    /// the elliptic sector it sweeps on the base disk has area ½|m_z|·γ(t), and the arc lies at
    /// r² = m_z²|v|²/(m_z²|v|² + (m_xy·v)²) along direction v. With unit d0, d1:
    /// S = |m_z|·(d0 × d1), C0 = m_z² + (m_xy·d0)², C1 = m_z² d0·d1 + (m_xy·d0)(m_xy·d1).
    struct Arc {
        double half_mz = 0, mz2 = 0, mx = 0, my = 0;
        double S = 0, C0 = 1, C1 = 1;
        /// m: the unit normal; d0, d1: the wedge's unit directions; cross = d0 × d1 (> 0).
        void set(const Vec3& m, const Vec2& d0, const Vec2& d1, double cross);
        double area(double t) const;
        /// d/dt and d²/dt² of area(t).
        void slopes(double t, double& d1, double& d2) const;
        double r2(const Vec2& v) const;
    };
    struct Cell {
        double area = 0;   // projected area on the base disk
        bool fan = false;  // true: elliptic sector of a great-circle arc (zenith inside)
        // fan: arc start a, in-plane unit b ⟂ a, angle gamma (local frame).
        Vec3 a = Vec3::Zero(), b = Vec3::Zero();
        double gamma = 0;
        // wedge: between the polar directions d0 and d1 (unit, in the wedge frame, which is the
        // local frame turned by (rc, rs)), bounded by the far and the near arc.
        Vec2 d0 = Vec2::Zero(), d1 = Vec2::Zero();
        double rc = 1, rs = 0;
        Arc far, near;
    };
    void add_piece(std::vector<Vec3>& local);
    /// Forgets the origin: no cells, no rejection set-up, zero total.
    void clear_origin();
    void build_cells();
    bool prepare_rejection(std::vector<Vec3>& unit);
    double sample_wedge(const Cell& c, double s) const;
    static constexpr std::size_t kMaxRejectionVertices = 8;

    std::vector<std::vector<Vec3>> pieces_;  // convex pieces of the target, world coordinates
    std::size_t piece_count_ = 0;            // pieces_[0, piece_count_) are in use
    Vec3 target_normal_ = Vec3::Zero();
    Vec3 target_point_ = Vec3::Zero();
    Vec3 t_ = Vec3::UnitX(), b_ = Vec3::UnitY(), n_ = Vec3::UnitZ();
    double total_ = 0.0;  // π F_{dA→A}
    // Directions of each clipped piece on the unit sphere (local frame), from set_origin().
    std::vector<std::vector<Vec3>> unit_pieces_;
    std::size_t unit_count_ = 0;
    // The inverse-map cells (built by set_origin(), or on demand in rejection mode).
    bool cells_ready_ = false;
    double cell_total_ = 0.0;
    std::vector<Cell> cells_;
    std::vector<double> cdf_;
    // Rejection: the proposal polygon's boundary, fan centre and cumulative triangle areas;
    // u_k × u_{k+1} of the target's edges.
    bool reject_ready_ = false;
    std::size_t unit_vertices_ = 0;
    std::vector<Vec2> proposal_;
    Vec2 proposal_centre_ = Vec2::Zero();
    std::vector<double> proposal_cdf_;
    double proposal_total_ = 0.0;
    std::vector<Vec3> edge_cross_;
    std::vector<Vec3> scratch_, local_;
    std::vector<double> psi_;
    std::vector<Vec2> dir_;
    std::vector<Vec3> edge_normal_;
    std::vector<std::size_t> far_, near_;
};

}  // namespace formfactor
