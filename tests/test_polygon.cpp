#include <doctest/doctest.h>

#include "formfactor/geometry/polygon.h"

using namespace formfactor;

TEST_CASE("polygon: area, normal and centroid of a unit square") {
    Polygon sq{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK(area(sq) == doctest::Approx(1.0).epsilon(1e-15));
    CHECK((normal(sq) - Vec3(0, 0, 1)).norm() < 1e-15);
    CHECK((centroid(sq) - Vec3(0.5, 0.5, 0)).norm() < 1e-15);
    CHECK(is_simple(sq));
    CHECK(planarity_defect(sq) == 0.0);
}

TEST_CASE("polygon: a bow tie is not simple, an L shape is") {
    Polygon bow{{Vec3(0, 0, 0), Vec3(1, 1, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}};
    CHECK_FALSE(is_simple(bow));
    Polygon ell{
        {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}};
    CHECK(is_simple(ell));
    CHECK(area(ell) == doctest::Approx(3.0).epsilon(1e-15));
    const auto tris = triangulate(ell);
    CHECK(tris.size() == 4);
    double sum = 0.0;
    for (const auto& t : tris) {
        Polygon tri{{ell[static_cast<std::size_t>(t[0])], ell[static_cast<std::size_t>(t[1])],
                     ell[static_cast<std::size_t>(t[2])]}};
        CHECK(normal(tri).z() > 0.0);
        sum += area(tri);
    }
    CHECK(sum == doctest::Approx(3.0).epsilon(1e-14));
}

TEST_CASE("polygon: clipping by a plane keeps the front part") {
    Polygon sq{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    Plane pl{Vec3(1, 0, 0), 0.25};
    const Polygon front = clip_to_front(sq, pl);
    CHECK(area(front) == doctest::Approx(0.75).epsilon(1e-15));
    Plane behind{Vec3(1, 0, 0), 2.0};
    CHECK(clip_to_front(sq, behind).size() == 0);
    Plane all{Vec3(1, 0, 0), -1.0};
    CHECK(area(clip_to_front(sq, all)) == doctest::Approx(1.0));
}

TEST_CASE("polygon: one convexity test for every caller") {
    const Polygon square{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK(convexity(square) == Convexity::strictly_convex);
    // A corner on an edge (as subdivision and clipping leave them): convex, not strictly.
    const Polygon straight{
        {Vec3(0, 0, 0), Vec3(0.5, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK(convexity(straight) == Convexity::convex);
    CHECK(is_convex(straight));
    // Bent inwards by far less than the tolerance: still straight.
    const Polygon almost{
        {Vec3(0, 0, 0), Vec3(0.5, 1e-14, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK(convexity(almost) == Convexity::convex);
    // Bent inwards by more: reflex.
    const Polygon dent{
        {Vec3(0, 0, 0), Vec3(0.5, 1e-6, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK(convexity(dent) == Convexity::not_convex);
    const Polygon ell{
        {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(0, 2, 0)}};
    CHECK_FALSE(is_convex(ell));
    // A spike (a straight corner that doubles back) and too few vertices are not convex.
    const Polygon spike{
        {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(1, 2, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    CHECK_FALSE(is_convex(spike));
    CHECK_FALSE(is_convex(Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0)}}));
}
