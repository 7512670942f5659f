// Convex partitions and polygons with holes (subtract_holes, overlap_area).

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "formfactor/geometry/polygon.h"
#include "formfactor/geometry/sampling.h"  // is_convex

using namespace formfactor;

namespace {

Polygon rect(double x0, double y0, double x1, double y1, double z = 0.0) {
    return Polygon{{Vec3(x0, y0, z), Vec3(x1, y0, z), Vec3(x1, y1, z), Vec3(x0, y1, z)}};
}

// The L shape: [0,2]×[0,1] ∪ [0,1]×[0,2], area 3.
Polygon ell() {
    return Polygon{
        {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}};
}

// Is x strictly inside the convex polygon c (counter-clockwise about n)?
bool strictly_inside(const Polygon& c, const Vec3& x, const Vec3& n) {
    for (std::size_t k = 0; k < c.size(); ++k) {
        const Vec3& a = c[k];
        const Vec3& b = c[(k + 1) % c.size()];
        if ((b - a).cross(x - a).dot(n) <= 1e-12) return false;
    }
    return true;
}

double total_area(const std::vector<Polygon>& pieces) {
    double a = 0.0;
    for (const Polygon& p : pieces) a += area(p);
    return a;
}

// Checks that the pieces are convex, face like p, and tile p minus the holes: every point of a
// fine grid (offset so as to miss the edges) lies in exactly one piece when it is in p and in no
// hole, in none otherwise. Returns the number of grid points where that fails.
int check_tiling(const Polygon& p, const std::vector<Polygon>& holes,
                 const std::vector<Polygon>& pieces, const std::vector<Polygon>& p_convex,
                 const std::vector<Polygon>& holes_convex) {
    const Vec3 n = normal(p);
    for (const Polygon& q : pieces) {
        CHECK(is_convex(q));
        CHECK(is_simple(q));
        CHECK((normal(q) - n).norm() < 1e-12);
    }
    const Bounds3 b = bounds(p);
    const PlaneFrame f = frame_of(p);
    int mismatches = 0;
    const int steps = 97;
    for (int i = 0; i < steps; ++i)
        for (int j = 0; j < steps; ++j) {
            // Grid over the bounds, in the plane of p.
            const Vec3 x =
                b.lo +
                (b.hi - b.lo).cwiseProduct(Vec3((i + 0.4142) / steps, (j + 0.7320) / steps, 0.5));
            const Vec3 y = f.to_world(f.to_local(x));
            int in_p = 0, in_hole = 0, in_piece = 0;
            for (const Polygon& c : p_convex) in_p += strictly_inside(c, y, n);
            for (const Polygon& c : holes_convex) in_hole += strictly_inside(c, y, n);
            for (const Polygon& c : pieces) in_piece += strictly_inside(c, y, n);
            const int expected = (in_p > 0 && in_hole == 0) ? 1 : 0;
            if (in_piece != expected) ++mismatches;
        }
    (void)holes;
    return mismatches;
}

}  // namespace

TEST_CASE("polygon: convex_partition (Hertel–Mehlhorn)") {
    CHECK(is_convex(rect(0, 0, 2, 1)));
    CHECK_FALSE(is_convex(ell()));
    // Collinear corners are allowed.
    CHECK(is_convex(Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0)}}));
    CHECK(convex_partition(rect(0, 0, 2, 1)).size() == 1);
    const auto parts = convex_partition(ell());
    CHECK(parts.size() == 2);  // the minimum for an L
    double sum = 0.0;
    for (const auto& part : parts) {
        Polygon q;
        for (int k : part) q.vertices.push_back(ell()[static_cast<std::size_t>(k)]);
        CHECK(is_convex(q));
        CHECK(normal(q).z() > 0.0);
        sum += area(q);
    }
    CHECK(sum == doctest::Approx(3.0).epsilon(1e-15));
}

TEST_CASE("polygon: subtract_holes tiles a rectangle minus an inner window into 4 pieces") {
    const Polygon wall = rect(0, 0, 4, 2.5);
    const Polygon window = rect(1, 0.8, 2.5, 2);
    const auto pieces = subtract_holes(wall, {window});
    CHECK(pieces.size() == 4);
    CHECK(total_area(pieces) == doctest::Approx(10.0 - 1.8).epsilon(1e-14));
    CHECK(0 == check_tiling(wall, {window}, pieces, {wall}, {window}));
    // The wall's own corners are kept bit for bit.
    int corners = 0;
    for (const Polygon& q : pieces)
        for (const Vec3& v : q.vertices)
            for (const Vec3& w : wall.vertices) corners += v == w;
    CHECK(corners >= 4);
    // The check itself notices a wrong tiling (the whole wall, window included).
    CHECK(check_tiling(wall, {window}, {wall}, {wall}, {window}) > 0);
}

TEST_CASE("polygon: holes touching the boundary or each other split the polygon cleanly") {
    const Polygon wall = rect(0, 0, 4, 2.5);
    SUBCASE("a door on the bottom edge") {
        const Polygon door = rect(1, 0, 2, 2);
        const auto pieces = subtract_holes(wall, {door});
        CHECK(pieces.size() == 3);
        CHECK(std::abs(total_area(pieces) - 8.0) <= 1e-14 * 10.0);
        CHECK(0 == check_tiling(wall, {door}, pieces, {wall}, {door}));
    }
    SUBCASE("a window in a corner") {
        const Polygon w = rect(3, 1.5, 4, 2.5);
        const auto pieces = subtract_holes(wall, {w});
        CHECK(pieces.size() == 2);
        CHECK(std::abs(total_area(pieces) - 9.0) <= 1e-14 * 10.0);
        CHECK(0 == check_tiling(wall, {w}, pieces, {wall}, {w}));
    }
    SUBCASE("a door as tall as the wall cuts it in two") {
        const Polygon door = rect(1, 0, 2, 2.5);
        const auto pieces = subtract_holes(wall, {door});
        CHECK(pieces.size() == 2);
        CHECK(std::abs(total_area(pieces) - 7.5) <= 1e-14 * 10.0);
        CHECK(0 == check_tiling(wall, {door}, pieces, {wall}, {door}));
    }
    SUBCASE("two windows sharing an edge, a third in a corner") {
        const std::vector<Polygon> holes{rect(0.5, 1, 1.5, 2), rect(1.5, 1, 2.5, 2),
                                         rect(3, 1.5, 4, 2.5)};
        const auto pieces = subtract_holes(wall, holes);
        CHECK(std::abs(total_area(pieces) - 7.0) <= 1e-14 * 10.0);
        CHECK(0 == check_tiling(wall, holes, pieces, {wall}, holes));
    }
    SUBCASE("a hole covering everything leaves nothing; one outside removes nothing") {
        CHECK(subtract_holes(wall, {wall}).empty());
        CHECK(subtract_holes(wall, {rect(-1, -1, 5, 3)}).empty());
        const auto pieces = subtract_holes(wall, {rect(5, 0, 6, 1)});
        REQUIRE(pieces.size() == 1);
        CHECK(area(pieces[0]) == 10.0);
    }
}

TEST_CASE("polygon: subtract_holes with non-convex polygons and holes, tilted in 3D") {
    // An L-shaped floor with an L-shaped hole (both non-convex), rotated out of the axis planes.
    const Polygon hole{{Vec3(0.2, 0.2, 0), Vec3(0.8, 0.2, 0), Vec3(0.8, 0.5, 0), Vec3(0.5, 0.5, 0),
                        Vec3(0.5, 1.6, 0), Vec3(0.2, 1.6, 0)}};
    const double hole_area = 0.6 * 0.3 + 0.3 * 1.1;
    const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
    auto moved = [&](Polygon p) {
        for (Vec3& v : p.vertices) v = R * v + Vec3(3, -1, 2);
        return p;
    };
    const Polygon base = moved(ell());
    const Polygon h = moved(hole);
    const auto pieces = subtract_holes(base, {h});
    CHECK(std::abs(total_area(pieces) - (3.0 - hole_area)) <= 1e-13 * 3.0);
    std::vector<Polygon> base_convex, hole_convex;
    for (const auto& part : convex_partition(base)) {
        Polygon q;
        for (int k : part) q.vertices.push_back(base[static_cast<std::size_t>(k)]);
        base_convex.push_back(q);
    }
    for (const auto& part : convex_partition(h)) {
        Polygon q;
        for (int k : part) q.vertices.push_back(h[static_cast<std::size_t>(k)]);
        hole_convex.push_back(q);
    }
    CHECK(0 == check_tiling(base, {h}, pieces, base_convex, hole_convex));
    // A hole given clockwise (facing away) cuts the same region.
    Polygon hr = h;
    std::reverse(hr.vertices.begin(), hr.vertices.end());
    CHECK(std::abs(total_area(subtract_holes(base, {hr})) - (3.0 - hole_area)) <= 1e-13 * 3.0);
}

TEST_CASE("polygon: overlap_area of coplanar polygons") {
    CHECK(overlap_area(rect(0, 0, 1, 1), rect(0.5, 0.5, 1.5, 1.5)) ==
          doctest::Approx(0.25).epsilon(1e-14));
    CHECK(overlap_area(rect(0, 0, 1, 1), rect(1, 0, 2, 1)) <= 1e-15);  // sharing an edge
    CHECK(overlap_area(rect(0, 0, 1, 1), rect(2, 0, 3, 1)) == 0.0);
    CHECK(overlap_area(ell(), rect(1.5, 1.5, 2, 2)) <= 1e-15);  // in the L's notch
    CHECK(overlap_area(ell(), rect(0.5, 0.5, 1.5, 1.5)) == doctest::Approx(0.75).epsilon(1e-14));
}
