#pragma once
/// Sampling points and directions for the Monte-Carlo methods: uniform points on a polygon,
/// cosine-weighted directions, and directions distributed by the projected solid angle of a
/// polygon (the Nusselt analogue). Each maps numbers in [0,1)² so that stratified and
/// low-discrepancy points keep their structure.

#include <algorithm>
#include <array>
#include <cmath>
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

    /// Sets the sending point x with unit normal n. Returns F_{dA→A}, the unoccluded form
    /// factor from x to the front of the polygon (0 when x does not see the front; then
    /// sample() must not be called).
    double set_origin(const Vec3& x, const Vec3& n);
    /// A unit direction (world coordinates) from x into the polygon's solid angle, density
    /// cosθ / (π F_{dA→A}) when (u, v) is uniform on [0,1)².
    Vec3 sample(double u, double v) const;
    /// F_{dA→A} of the last set_origin().
    double form_factor() const { return total_ * kInvPi; }

  private:
    /// An edge's ellipse in polar form about the disk centre: with θ = φ − β,
    /// r²(φ) = a²/(a² + ρ² cos²θ) and sector area S(φ) = ½ a · atan2(a sin θ, cos θ) + const,
    /// where a = |m_z|, ρ = |m_xy| and β = atan2(m_y, m_x) for the great circle's normal m.
    struct Arc {
        double a = 0, rho = 0, cb = 1, sb = 0;
        double e0 = 0;  // E(φ0) = atan2(a sin θ0, cos θ0) at the wedge's start
        void set(const Vec3& m);
        double E(double c, double s) const;   // at direction (cos φ, sin φ) = (c, s)
        double r2(double c, double s) const;  // r² there
    };
    struct Cell {
        double area = 0;   // projected area on the base disk
        bool fan = false;  // true: elliptic sector of a great-circle arc (zenith inside)
        // fan: arc start a, in-plane unit b ⟂ a, angle gamma. wedge: polar angles [phi0, phi1],
        // far and near arcs; a, b rotate the wedge frame back.
        Vec3 a = Vec3::Zero(), b = Vec3::Zero();
        double gamma = 0;
        double phi0 = 0, phi1 = 0;
        double c0 = 1, s0 = 0, c1 = 1, s1 = 0;  // cos, sin of phi0 and phi1
        Arc far, near;
    };
    void add_piece(std::vector<Vec3>& local);
    double sample_wedge_angle(const Cell& c, double s) const;

    std::vector<std::vector<Vec3>> pieces_;  // convex pieces of the target, world coordinates
    std::size_t piece_count_ = 0;            // pieces_[0, piece_count_) are in use
    Vec3 target_normal_ = Vec3::Zero();
    Vec3 target_point_ = Vec3::Zero();
    Vec3 t_ = Vec3::UnitX(), b_ = Vec3::UnitY(), n_ = Vec3::UnitZ();
    double total_ = 0.0;
    std::vector<Cell> cells_;
    std::vector<double> cdf_;
    std::vector<Vec3> scratch_, local_;
    std::vector<double> psi_;
    std::vector<std::size_t> far_, near_;
};

/// True when the planar polygon is convex (no reflex vertex about its normal).
bool is_convex(const Polygon& p);

}  // namespace formfactor
