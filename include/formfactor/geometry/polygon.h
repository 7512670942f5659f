#pragma once
/// Planar polygons: the patches of DESIGN.md. Vertices run counter-clockwise seen from the
/// front; the right-hand (Newell) normal is the front.

#include <array>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor {

/// A planar simple polygon (convex or not), one-sided.
struct Polygon {
    std::vector<Vec3> vertices;

    std::size_t size() const { return vertices.size(); }
    const Vec3& operator[](std::size_t k) const { return vertices[k]; }
    Vec3& operator[](std::size_t k) { return vertices[k]; }
};

/// Newell's vector area: ½ Σ v_k × v_{k+1}; its length is the area of a planar polygon and its
/// direction the front normal.
Vec3 area_vector(const Polygon& p);
/// Area of a planar polygon (|area_vector|).
double area(const Polygon& p);
/// Unit front normal (zero vector for a degenerate polygon).
Vec3 normal(const Polygon& p);
/// Area centroid of a planar polygon.
Vec3 centroid(const Polygon& p);
/// The polygon's plane, oriented by its front normal, through its centroid.
Plane plane_of(const Polygon& p);
/// Axis-aligned bounds of the vertices.
Bounds3 bounds(const Polygon& p);
/// Longest edge length.
double max_edge_length(const Polygon& p);
/// Largest distance between two vertices (diameter); a length scale for tolerances.
double diameter(const Polygon& p);
/// Largest distance of a vertex from the polygon's plane, divided by its diameter.
double planarity_defect(const Polygon& p);
/// True when no two non-adjacent edges touch and no vertex repeats (checked in the plane).
bool is_simple(const Polygon& p);

/// Relative tolerance of every convexity test: a corner (edges e0 into it, e1 out of it) whose
/// turn |(e0 × e1) · n| is at most kConvexityTolerance · |e0| |e1| is straight (collinear).
inline constexpr double kConvexityTolerance = 1e-12;

/// How convex a polygon is about its own normal (normal()): every corner turns left
/// (strictly_convex); or left or straight (convex: collinear corners, as clipping and
/// subdivision leave them); or some corner turns right, or is straight but doubles back (a
/// spike), or there are fewer than 3 vertices (not_convex). A degenerate polygon (zero normal)
/// has only straight corners. kConvexityTolerance decides what is straight.
enum class Convexity { not_convex, convex, strictly_convex };
Convexity convexity(const Polygon& p);
/// True when the polygon is convex, collinear corners allowed (convexity(p) != not_convex).
bool is_convex(const Polygon& p);

/// Coordinates in the polygon's plane: origin at the centroid, axes (u, v) orthonormal with
/// u × v = normal. Used for 2D tests and sampling.
struct PlaneFrame {
    Vec3 origin;
    Vec3 u, v, n;
    Vec2 to_local(const Vec3& x) const { return {u.dot(x - origin), v.dot(x - origin)}; }
    Vec3 to_world(const Vec2& p) const { return origin + p.x() * u + p.y() * v; }
};
PlaneFrame frame_of(const Polygon& p);
/// An orthonormal basis (u, v) completing the unit vector n, u × v = n.
void orthonormal_basis(const Vec3& n, Vec3& u, Vec3& v);

/// The part of p on the front side of the plane (signed distance ≥ 0), Sutherland–Hodgman.
/// Vertices within `eps` of the plane count as on it. Works for non-convex polygons too (the
/// result may then contain zero-width bridges, which integrate to zero). An empty polygon
/// (size() < 3) means nothing is in front.
Polygon clip_to_front(const Polygon& p, const Plane& plane, double eps = 0.0);

/// Triangulation by ear clipping (any simple polygon): index triples into p.vertices, each
/// counter-clockwise about the polygon's normal.
std::vector<std::array<int, 3>> triangulate(const Polygon& p);

/// A partition of a simple polygon into convex polygons: p itself when convex, else the
/// ear-clipping triangles (triangulate()) merged greedily across shared diagonals while the
/// union stays convex (Hertel–Mehlhorn; at most 4× the minimum number of pieces). Each piece is
/// a cycle of indices into p.vertices, counter-clockwise about p's normal. Zero-area triangles
/// of the triangulation are dropped.
std::vector<std::vector<int>> convex_partition(const Polygon& p);

/// p minus the union of `holes`, as convex polygons that tile it exactly (up to rounding), each
/// counter-clockwise about p's normal. The holes are taken in p's plane: each convex part of a
/// hole (convex_partition) is extruded along p's normal and cut away from every piece with one
/// Sutherland–Hodgman clip per hole edge (the part outside that edge is kept as a piece, the
/// rest goes on to the next edge). Holes may touch p's boundary or each other (the pieces then
/// simply end there); a hole outside p removes nothing. Vertices of p are kept bit for bit;
/// vertices within 1e-12 · diameter(p) of a cut line count as on it; collinear corners are
/// removed and pieces of area ≤ 1e-15 · diameter(p)² (rounding slivers) dropped. Without holes
/// the result is the convex partition of p.
std::vector<Polygon> subtract_holes(const Polygon& p, const std::vector<Polygon>& holes);

/// Area of the overlap of two coplanar polygons (b taken in a's plane, projected along a's
/// normal): area(a) − Σ area(subtract_holes(a, {b})). Zero for disjoint or edge-sharing
/// polygons (up to rounding).
double overlap_area(const Polygon& a, const Polygon& b);

}  // namespace formfactor
