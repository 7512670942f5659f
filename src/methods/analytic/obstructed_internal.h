#pragma once
// Internals of the obstruction-aware analytic method (not public API): convex blocker pieces in
// a BVH (blocker_set.cpp), conservative shaft classification of polygon pairs (shaft.cpp), and
// the adaptive integration of the hidden part of a partly hidden pair (point_kernel.cpp,
// umbrae.cpp, hidden_integral.cpp, with discontinuity_mesh.cpp and shadow_clip.{h,cpp}). See
// docs/analytic.md, "Obstructed scenes".

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"
#include "geometry/box_tree.h"

namespace formfactor::detail {

/// Largest vertex count of a convex piece (larger convex polygons are triangulated).
inline constexpr int kMaxPieceVertices = 12;

/// The convex planar pieces of every blocking polygon (patches' surfaces and obstruction-only
/// surfaces), with a bounding-volume hierarchy over their boxes. Double precision throughout.
class BlockerSet {
  public:
    struct Piece {
        int first = 0, count = 0;  ///< vertices [first, first + count) of vertices()
        Plane plane;               ///< oriented by the piece's own (Newell) normal
        Bounds3 box;
        int surface = -1;  ///< the blocking surface it belongs to
        /// Part of a closed, outward-oriented solid with no other geometry inside: a segment
        /// from a point x that crosses the solid also crosses a piece with x in front, so the
        /// pieces with x behind (or in) their plane can be skipped for x.
        bool cull_back = false;
        /// Of a surface that can block nothing (every patch on one side of its plane): query()
        /// leaves it out (kept in the tree, so that the others come in the same order).
        bool inert = false;
        /// The convex solid (closed, or open along one planar loop of edges) of the piece, −1
        /// for none: unless cull_back, a point may skip its back faces only where culls_at()
        /// says so (see mark_closed_solids()).
        int solid = -1;
    };

    /// Adds polygon p of surface `surface` (split into convex pieces).
    void add(const Polygon& p, int surface);
    /// The convex pieces add() makes of p: p itself when convex (≤ kMaxPieceVertices vertices),
    /// else its triangles.
    static std::vector<Polygon> convex_parts(const Polygon& p);
    /// Builds the hierarchy; call once after the last add(). The pieces of the surfaces s with
    /// `inert[s]` set are never found by query() (Piece::inert).
    void build(const std::vector<char>& inert = {});
    /// Finds the closed solids (connected pieces whose every edge is matched by the reversed
    /// edge of another piece, positive signed volume) and sets Piece::cull_back on their pieces,
    /// unless the bounding box of one of `patches` (with the surface id it belongs to) not on
    /// the solid meets or touches the solid's bounding box: a point on the solid's surface (a
    /// floor under a box resting on it, a face in contact with the solid's face) starts segments
    /// that enter the solid without crossing a face it is in front of. `tol`: length for
    /// matching vertices and for touching.
    /// The convex solids among the rest get Piece::solid instead, for culling point by point
    /// (culls_at()): closed ones that touch other patches, and connected pieces whose unmatched
    /// edges form one planar loop (an open box standing on a floor, a building on the ground),
    /// convex when closed by that loop. Inert pieces (Piece::inert) join no solid and match no
    /// edge: a building on a triangulated ground that shares its footprint's edges is open along
    /// that footprint, not one component with the ground. Call after build().
    void mark_closed_solids(const std::vector<std::pair<Bounds3, int>>& patches, double tol);

    /// True when, for the point x, the pieces of convex solid `solid` that x is behind (or in
    /// the plane of) can be skipped: x is strictly outside the solid (in front of one of its
    /// faces by more than the solid's tolerance) and, for a solid open along a planar loop, not
    /// in front of the plane of that opening. Then a segment from x that meets the solid enters
    /// it through a face x is in front of (it cannot enter through the opening).
    bool culls_at(int solid, const Vec3& x) const;
    /// culls_at() when x's signed distance to the plane of one of the solid's faces is known:
    /// in front of it by more than the tolerance decides at once (no loop over the faces).
    bool culls_at(int solid, const Vec3& x, double face_distance) const;
    /// True when convex solid `solid` hides every segment between the convex polygons a (na
    /// vertices) and b (nb): neither reaches into it (each on or in front of one of its planes),
    /// and every segment between a vertex of a and a vertex of b meets it (in more than one
    /// point: a polygon on one of its faces touches it wherever it looks). The points x whose
    /// segment to a fixed point y meets a convex solid form a convex set (and so do the points
    /// y for a fixed x), so the vertex segments decide for all points; a segment between two
    /// points outside that passes through the interior crosses the boundary twice, at most once
    /// through a planar opening, so one of the faces blocks it, and those that only graze the
    /// solid are of measure zero.
    bool solid_hides(int solid, const Vec3* a, int na, const Vec3* b, int nb) const;
    /// True when convex solid `solid` is open along a planar loop of edges (no face there).
    bool solid_open(int solid) const { return solids_[static_cast<std::size_t>(solid)].open; }
    /// The bounding box of convex solid `solid`'s vertices.
    const Bounds3& solid_box(int solid) const {
        return solids_[static_cast<std::size_t>(solid)].box;
    }
    /// The vertices of convex solid `solid`, each once, when it has few pieces (up to 16: a
    /// box, a building, triangulated or not); else empty.
    const std::vector<Vec3>& solid_corners(int solid) const {
        return solids_[static_cast<std::size_t>(solid)].corners;
    }
    /// True when every corner of convex solid `solid` is a corner of its box (then the box is
    /// its hull).
    bool solid_box_is_hull(int solid) const {
        return solids_[static_cast<std::size_t>(solid)].box_is_hull;
    }
    /// The face planes of convex solid `solid` (outward).
    const std::vector<Plane>& solid_faces(int solid) const {
        return solids_[static_cast<std::size_t>(solid)].faces;
    }
    /// The number of convex solids (the range of Piece::solid).
    int solid_count() const { return static_cast<int>(solids_.size()); }
    /// culls_at() for every point of the convex polygon v[0..n) (checked on its vertices, one
    /// face for all).
    bool culls_all(int solid, const Vec3* v, int n) const;
    /// Whether piece k may be skipped for the point x: x is behind or in its plane, and the
    /// piece's solid allows it there (always for closed solids apart from other geometry).
    bool skip_back_face(int k, const Vec3& x) const {
        const Piece& pc = pieces_[static_cast<std::size_t>(k)];
        if (pc.plane.signed_distance(x) > 0.0) return false;
        return pc.cull_back || (pc.solid >= 0 && culls_at(pc.solid, x));
    }
    /// True when culling of piece k's solid holds for every point of the convex polygon v.
    bool culls_polygon(int k, const Vec3* v, int n) const {
        const Piece& pc = pieces_[static_cast<std::size_t>(k)];
        return pc.cull_back || (pc.solid >= 0 && culls_all(pc.solid, v, n));
    }

    std::size_t size() const { return pieces_.size(); }
    const Piece& piece(int k) const { return pieces_[static_cast<std::size_t>(k)]; }
    const Vec3* vertices(int k) const {
        return verts_.data() + pieces_[static_cast<std::size_t>(k)].first;
    }
    /// The piece across edge e (from vertex e to e + 1) of piece k in its closed solid, else −1
    /// (set by mark_closed_solids()).
    int neighbor(int k, int e) const {
        if (neighbor_.empty()) return -1;
        return neighbor_[static_cast<std::size_t>(pieces_[static_cast<std::size_t>(k)].first + e)];
    }

    /// Appends to `out` the pieces whose box may meet the shaft, skipping the pieces of
    /// surfaces skip_a and skip_b.
    void query(const class Shaft& shaft, int skip_a, int skip_b, std::vector<int>& out) const;

  private:
    std::vector<Vec3> verts_;
    std::vector<int> neighbor_;  // per vertex of verts_: the piece across the edge it starts
    std::vector<Piece> pieces_;
    // The convex solids of Piece::solid: their face planes (outward), the plane of their
    // opening when open, and the tolerance of "strictly in front".
    struct Solid {
        std::vector<Plane> faces;
        bool open = false;
        Plane opening;
        double tol = 0;
        // Balls about the vertices' centroid: every vertex within r_out of it, every face plane
        // (and the opening's) at least r_in from it (see solid_hides()).
        Vec3 centre = Vec3::Zero();
        double r_out = 0, r_in = 0;
        Bounds3 box;                // of its vertices
        std::vector<Vec3> corners;  // its vertices, each once, when it has few pieces (a box)
        bool box_is_hull = false;   // every corner is a corner of `box` (a box along the axes)
    };
    std::vector<Solid> solids_;
    BoxTree tree_;  // over the pieces' boxes
};

/// The shaft of two planar convex polygons a and b: the planes bounding their convex hull (the
/// union of the segments between them): a's and b's own planes (nothing behind either can block)
/// and the hull's side faces through an edge of one polygon and a vertex of the other.
class Shaft {
  public:
    /// a, b: vertices of planar convex polygons (counter-clockwise about na, nb, their unit
    /// front normals); eps: the length below which a blocker's overlap is ignored.
    void build(const Vec3* a, int na, const Vec3& normal_a, const Vec3* b, int nb,
               const Vec3& normal_b, double eps);
    /// True when nothing in the box can meet the shaft.
    bool box_outside(const Bounds3& box) const;
    /// −1 when nothing in the box can meet the shaft (box_outside()); 0 when the box may meet it
    /// but lies strictly inside one of its side planes, so that nothing in the box can hide the
    /// segments on that side face (a convex solid in it hides no shaft: solid_hides() would
    /// find a vertex segment on that face that misses it); else 1.
    int box_relation(const Bounds3& box) const;
    /// box_relation() for the convex hull of the points p[0..n).
    int points_relation(const Vec3* p, int n) const;
    /// True when a and b are both on or in front of the plane (within eps): no segment between
    /// them enters the half-space behind it.
    bool in_front_of(const Plane& pl) const;
    /// True when the convex polygon p (count vertices, plane pl) cannot block a segment of the
    /// shaft: a separating plane among the shaft's planes and p's own plane, and when `exact`,
    /// also among the edge-edge axes (then the test is exact: false means p meets the hull).
    bool piece_outside(const Vec3* p, int count, const Plane& pl, bool exact = true) const;
    /// True when the convex polygon p blocks every segment between a and b.
    bool piece_hides(const Vec3* p, int count, const Plane& pl) const;
    /// Every vertex of b is behind or on a's plane, or every vertex of a behind b's plane: F = 0.
    bool facing_away() const { return facing_away_; }
    /// The two polygons of build().
    const Vec3* a() const { return a_; }
    const Vec3* b() const { return b_; }
    int a_count() const { return na_; }
    int b_count() const { return nb_; }

  private:
    const Vec3* a_ = nullptr;
    const Vec3* b_ = nullptr;
    int na_ = 0, nb_ = 0;
    Plane pa_, pb_;
    Plane side_[2 * kMaxPieceVertices + 2];
    int sides_ = 0;
    Vec3 link_[4 * kMaxPieceVertices];  // directions of the hull's edges between a and b
    int links_ = 0;
    Vec3 ca_, cb_;  // vertex averages
    double eps_ = 0;
    bool facing_away_ = false;
};

enum class ShaftClass : std::uint8_t { kVisible, kHidden, kPartial };

/// Classifies the pair behind `shaft` against the candidate pieces cand[0..n): kHidden when one
/// piece, or the convex solid of some of them (BlockerSet::solid_hides()), hides every
/// segment, kVisible when none can block, else kPartial with `kept` = the pieces that may block
/// (a subset of cand, in order). by_solid: a small convex solid is placed as a whole; when it
/// may block, all its pieces are kept untested (more than the pieces that meet the shaft: for
/// the node pairs above patch pairs, whose lists only seed their children's).
ShaftClass classify_shaft(const Shaft& shaft, const BlockerSet& blockers, const int* cand, int n,
                          std::vector<int>& kept, bool exact = true, bool by_solid = false);

/// Convex hull of the planar points (counter-clockwise about the unit normal n), collinear
/// points dropped.
std::vector<Vec3> planar_convex_hull(const std::vector<Vec3>& points, const Vec3& n);

/// Andrew's monotone chain on points with members x and y: sorts `points` and writes their convex
/// hull, counter-clockwise, collinear points dropped, to `hull` (resized to its vertex count; 0,
/// 1 or 2 vertices for degenerate input). The one hull routine of planar_convex_hull() and the
/// point kernel's shadow merge.
template <class P>
void convex_hull_2d(std::vector<P>& points, std::vector<P>& hull) {
    if (points.empty()) {
        hull.clear();
        return;
    }
    std::sort(points.begin(), points.end(),
              [](const P& a, const P& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    auto cross = [](const P& o, const P& a, const P& b) {
        return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    };
    // Room for the chain, whatever hull held (every element is written before it is read).
    const std::size_t n = points.size();
    hull.resize(2 * n);
    P* h = hull.data();
    const P* pt = points.data();
    std::size_t m = 0;
    for (std::size_t k = 0; k < n; ++k) {
        while (m >= 2 && cross(h[m - 2], h[m - 1], pt[k]) <= 0) --m;
        h[m++] = pt[k];
    }
    for (std::size_t k = n - 1, t = m + 1; k-- > 0;) {
        while (m >= t && cross(h[m - 2], h[m - 1], pt[k]) <= 0) --m;
        h[m++] = pt[k];
    }
    hull.resize(m > 0 ? m - 1 : 0);
}

/// The result of integrating the hidden part of a partly hidden pair over the sender.
struct HiddenIntegral {
    double hidden = 0;              ///< 1/A_s ∫_s F(x → hidden part of r) dA_x
    double error = 0;               ///< estimated absolute error of `hidden`
    int max_level = 0;              ///< deepest subdivision of the sender (0 = the whole sender)
    std::size_t cells = 0;          ///< final cells
    std::size_t points = 0;         ///< point evaluations
    std::size_t closed_forms = 0;   ///< cells in an umbra, integrated in closed form
    std::size_t proven_hidden = 0;  ///< of those, cells found hidden by their corners' umbrae
    std::size_t bracketed = 0;      ///< final cells settled by their brackets, not integrated
    bool capped = false;            ///< stopped at the cell limit before meeting the target
};

/// 1/A_s ∫_s F_{dA_x → (r ∩ shadows of the pieces seen from x)} dA_x: the part of F_sr that the
/// candidate pieces hide, by adaptive subdivision of the sender (Gauss 2×2 against 3×3 per
/// cell, cells classified by their own shafts first), until the estimated error ≤ target.
/// s and r: planar convex polygons (counter-clockwise about their normals). `cut`, when given:
/// split_by_events(s, normal(s), Receiver(r), blockers, cand, n, eps), computed already.
/// `seed`: the stream of uniform() that places the points of cells settled by their umbrae
/// (the pair's own, so that the result is the same on any thread count).
HiddenIntegral hidden_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                               const int* cand, int n, double target, double eps,
                               const std::vector<Polygon>* cut = nullptr, std::uint64_t seed = 0);

/// split_by_events() of the sender s towards the receiver r (convex polygons): what
/// hidden_integral(s, r, ...) integrates over, for its `cut`; empty when it would have
/// max_pieces pieces or more. budget_spent, when given: whether split_by_events() left event
/// lines uncut once its piece budget was spent.
std::vector<Polygon> event_pieces(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                                  const int* cand, int n, double eps,
                                  std::size_t max_pieces = SIZE_MAX, bool* budget_spent = nullptr);

/// A bound on what the sender s sees of r past the candidate pieces (1/A_s ∫_s F(x → visible
/// part of r) dA_x ≤ bound): F from s to r less the umbrae of the occluders, the points of r
/// hidden from every corner of s by one convex solid or piece (cell_umbra()'s test), by Gauss
/// rules of orders 2 and 3 with kAgreement × their difference added. `ok` is false when no
/// occluder has an umbra; the bound is left once it exceeds give_up. `estimate`: the visible
/// part at one point drawn in each quarter of the unit square that maps onto s (the stream
/// `seed` of uniform(): fixed points would err the same way in the similar pairs of a row),
/// inside [0, bound] (only when bound ≤ give_up).
struct VisibleBound {
    bool ok = false;
    double bound = 0, estimate = 0;
    std::size_t points = 0;
};
VisibleBound visible_bound(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                           const int* cand, int n, double eps, double give_up,
                           std::uint64_t seed = 0);

/// The part of the sender s that may see some of r: s less the umbrae that the occluders cast on
/// s's plane with r as the light, the points x from which one convex solid or piece hides all of
/// r (cell_umbra()'s test with the two patches' roles swapped: the intersection of its shadows
/// from r's corners). Nothing of r is seen from the rest of s. Convex polygons, counter-clockwise
/// about s's normal, into `out`; false (out empty) when no occluder has an umbra on s.
bool seeing_part(const Polygon& s, const Polygon& r, const BlockerSet& blockers, const int* cand,
                 int n, double eps, std::vector<Polygon>& out);

/// F(s → r) over the parts of s that may see r (seeing_part()), each part's unobstructed closed
/// form less its hidden part (hidden_integral(), cut along its own event lines, the candidates
/// its shaft keeps), to `target` in all: `ok` false, nothing done, when no occluder has an umbra
/// on s or those parts exceed `share` of s's area (seen_integral.cpp).
struct SeenIntegral {
    bool ok = false;
    double value = 0, error = 0;
    std::size_t points = 0, cells = 0, closed_forms = 0, proven_hidden = 0, bracketed = 0,
                parts = 0;
    int max_level = 0;
    bool capped = false;
};
SeenIntegral seen_integral(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                           const int* cand, int n, double target, double eps, double share,
                           std::uint64_t seed = 0);

/// A low-order estimate of hidden_integral()'s value (three points per triangle of s's fan, a
/// rule of degree 2), without an error estimate: for a pair whose bracket 0 ≤ hidden ≤ F(s → r)
/// is already inside its tolerance, to place the value inside the bracket. `points` counts the
/// point evaluations.
double hidden_estimate(const Polygon& s, const Polygon& r, const BlockerSet& blockers,
                       const int* cand, int n, double eps, std::size_t& points);

struct Receiver;  // shadow_clip.h

/// The sender s (unit normal ns) cut into convex pieces along the lines where
/// F(x → part of rc hidden by the candidate pieces) has kinks (discontinuity meshing); the
/// convex parts of s when nothing cuts it; empty when the cut would have max_pieces pieces or
/// more (the caller has a cut with fewer). budget_spent, when given: set when the cut reached
/// its piece budget (1,024; 4,096 graded towards near contact) with event lines left uncut,
/// across whose kinks the rules may then agree.
std::vector<Polygon> split_by_events(const Polygon& s, const Vec3& ns, const Receiver& rc,
                                     const BlockerSet& blockers, const int* cand, int n, double eps,
                                     std::size_t max_pieces = SIZE_MAX,
                                     bool* budget_spent = nullptr);

/// True when the segment p0 p1 meets the interior of the convex counter-clockwise polygon q
/// (by more than tol): split_by_events()'s test of a bounded event line against a piece.
bool segment_crosses(const Vec2& p0, const Vec2& p1, const std::vector<Vec2>& q, double tol);

/// F from a point x (unit normal n) to the part of the convex polygon r hidden by the pieces:
/// Lambert's formula on the union of the pieces' central projections (shadows) from x onto r's
/// plane, clipped to the pyramid from x over r. unobstructed, when not null, receives F(x → r).
double point_hidden(const Vec3& x, const Vec3& n, const Polygon& r, const BlockerSet& blockers,
                    const int* cand, int count, double eps, double* unobstructed = nullptr);

}  // namespace formfactor::detail
