#pragma once
/// Exact (unobstructed) form factors between planar polygons, and the fast far-field quadrature
/// that the `analytic` method uses for well-separated pairs. See docs/analytic.md for the
/// algorithms and the error model.

#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor {

/// F_{dA→A}: the form factor from a differential element at `x` with unit normal `n` to the
/// one-sided polygon `p` (vertices counter-clockwise seen from its front), unobstructed.
/// Lambert's contour formula F = 1/(2π) Σ_k γ_k n·(R_k × R_{k+1})/|R_k × R_{k+1}| applied to
/// the part of p in front of the element (p is clipped by the element's plane first). Zero when
/// x is behind p or in its plane. Exact up to rounding (~1e-15).
double point_to_polygon(const Vec3& x, const Vec3& n, const Polygon& p);

/// F_ab: the exact unobstructed form factor from polygon a to polygon b (both planar, simple,
/// convex or not, one-sided, vertices counter-clockwise seen from the front). Each polygon is
/// clipped to the other's front half-space, then the double contour integral
/// A_a F_ab = 1/(2π) ∮_a ∮_b ln r dx_a·dx_b (Stokes; Sparrow 1963, Mitalas & Stephenson 1966) is
/// evaluated edge pair by edge pair: parallel edges in closed form, other pairs with the inner
/// integral in closed form and the outer by adaptive Gauss–Kronrod with breakpoints at the
/// points where the edges come close. Handles shared edges and vertices, touching and crossing
/// planes; coplanar or facing-away pairs give 0. Absolute error ≲ 1e-12.
double polygon_to_polygon(const Polygon& a, const Polygon& b);

/// Quadrature rule over one planar polygon: points and weights (weights sum to the area).
/// Quads use the tensor Gauss–Legendre rule of the bilinear map, triangles the collapsed
/// (Duffy) tensor rule, other polygons a triangulation; `order` points per direction.
struct PolygonRule {
    std::vector<Vec3> points;
    std::vector<double> weights;
};
PolygonRule polygon_rule(const Polygon& p, int order);

/// F_ab by the tensor product of polygon_rule(a, order_a) and polygon_rule(b, order_b) applied
/// to the kernel cosθ_a cosθ_b/(π r²) (the far-field path). Only valid when each polygon lies
/// in front of the other's plane (no clipping is done) and they are well separated; the error
/// is bounded by far_field_error_bound.
double polygon_to_polygon_quadrature(const Polygon& a, const Polygon& b, int order_a, int order_b);

/// Geometry of a pair for the far-field error model: circumradii about the area centroids and
/// the centroid distance.
struct FarFieldPair {
    double radius_a = 0, radius_b = 0;  ///< max distance of a vertex from the centroid
    double area_a = 0, area_b = 0;
    double distance = 0;  ///< |c_a − c_b|
};

/// Bound on the absolute error of F_ab (and of F_ba) computed by the far-field quadrature with
/// `order_a`, `order_b` points per direction: max(A_a, A_b)/(π d_min²) · (g(order_a, R_a/d') +
/// g(order_b, R_b/d')) with d_min = d − R_a − R_b, d' = d − R_b (resp. d − R_a), and g the
/// Gauss–Legendre Bernstein-ellipse factor calibrated in docs/analytic.md. Infinity when the
/// pair is not separated (d ≤ R_a + R_b).
double far_field_error_bound(const FarFieldPair& pair, int order_a, int order_b);

/// Largest order the far-field path uses (points per direction).
inline constexpr int kMaxFarFieldOrder = 8;

}  // namespace formfactor
