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

}  // namespace formfactor
