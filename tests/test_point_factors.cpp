// point_form_factors: differential elements to every patch, exact with obstructions, many points at
// once, thread-count independence.

#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/obstructed.h"
#include "formfactor/methods/point_factors.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene.h"
#include "support/scenes.h"

using namespace formfactor;
using formfactor::testing::quad;
using formfactor::testing::scene_of;

namespace {

// F from a point under the centre of a unit square at height 1 (C-style closed form).
constexpr double kUnobstructed = 0.23945647046077354;
// The same square with a centred square of half-width 0.3 hidden: F(0.5) − F(0.3).
constexpr double kRing = 0.1370846812475841;

// The unit square [0, 1]² at z = 1 facing −z, and a blocker square of half-width w centred over
// (0.5, 0.5) at height z.
Scene square_and_blocker(double w, double z) {
    const Polygon receiver =
        quad(Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1));  // normal −z
    const double a = 0.5 - w, b = 0.5 + w;
    const Polygon blocker = quad(Vec3(a, a, z), Vec3(b, a, z), Vec3(b, b, z), Vec3(a, b, z));
    return scene_of({receiver}, {blocker});
}

double at_origin_up(const Scene& s, int threads = 0) {
    return point_form_factors(s, {Vec3(0.5, 0.5, 0)}, {Vec3(0, 0, 1)}, threads)(0, 0);
}

}  // namespace

TEST_CASE("point factors: an obstruction square between a point and a unit square") {
    // Unobstructed: the closed form.
    CHECK(std::abs(at_origin_up(scene_of({square_and_blocker(0.1, 0.5).surfaces[0].polygon})) -
                   kUnobstructed) < 1e-14);
    // The reported case: a shadow of half-width 0.3 on the square, from a blocker [0.25, 0.75]²
    // at z = 5/6 or [0.35, 0.65]² at z = 0.5 (the reported [0.25, 0.75]² at z = 0.5 casts a
    // shadow of half-width 0.5: the whole square, below).
    CHECK(std::abs(at_origin_up(square_and_blocker(0.25, 5.0 / 6.0)) - kRing) < 1e-13);
    CHECK(std::abs(at_origin_up(square_and_blocker(0.15, 0.5)) - kRing) < 1e-13);
    CHECK(std::abs(at_origin_up(square_and_blocker(0.25, 0.5))) < 1e-14);
    // A blocker beside the pyramid from the point over the square hides nothing.
    const Polygon receiver = square_and_blocker(0.1, 0.5).surfaces[0].polygon;
    const Scene beside = scene_of(
        {receiver}, {quad(Vec3(2, 0, 0.5), Vec3(3, 0, 0.5), Vec3(3, 1, 0.5), Vec3(2, 1, 0.5))});
    CHECK(at_origin_up(beside) == point_to_polygon(Vec3(0.5, 0.5, 0), Vec3(0, 0, 1), receiver));
}

TEST_CASE("point factors: every patch blocks, obstructions block, rows close inside a room") {
    // A point below the room's floating box, facing up: the box (patches) hides part of the
    // ceiling; the rows close (the room is closed).
    const Scene with_box = room_scene(4, RoomBox::kPatches);
    const Scene obstruction_box = room_scene(4, RoomBox::kObstruction);
    const Scene empty_room = room_scene(4, RoomBox::kNone);
    const std::vector<Vec3> x = {Vec3(0.5, 0.5, 0.05), Vec3(0.2, 0.7, 0.6), Vec3(0.9, 0.1, 0.3)};
    const std::vector<Vec3> n = {Vec3(0, 0, 1), Vec3(1, -1, 0.5), Vec3(-1, 0.2, 0.1)};
    const DenseMatrix F = point_form_factors(with_box, x, n);
    const DenseMatrix G = point_form_factors(obstruction_box, x, n);
    const DenseMatrix E = point_form_factors(empty_room, x, n);
    REQUIRE(F.rows() == 3);
    REQUIRE(F.cols() == static_cast<Eigen::Index>(with_box.patches.size()));
    const Eigen::Index walls = static_cast<Eigen::Index>(empty_room.patches.size());
    for (Eigen::Index m = 0; m < 3; ++m) {
        CAPTURE(m);
        CHECK(std::abs(F.row(m).sum() - 1.0) < 1e-12);
        CHECK(std::abs(E.row(m).sum() - 1.0) < 1e-12);
        // The walls see the same past the box whether it has patches or only blocks.
        CHECK((F.row(m).head(walls) - G.row(m)).cwiseAbs().maxCoeff() < 1e-13);
        // Blocked: never above the unobstructed value, and something is hidden.
        CHECK((F.row(m).head(walls).array() <= E.row(m).array() + 1e-15).all());
        CHECK(F.row(m).tail(F.cols() - walls).sum() > 0.01);
    }
    // Element 0 faces up from under the box: the ceiling above the box is hidden.
    CHECK(F.row(0).head(walls).sum() < E.row(0).sum() - 0.1);
}

TEST_CASE("point factors: many points equal one at a time, and do not depend on the threads") {
    const Scene s = room_scene(4, RoomBox::kObstruction);
    std::vector<Vec3> x, n;
    for (int k = 0; k < 7; ++k) {
        x.emplace_back(0.1 + 0.12 * k, 0.9 - 0.1 * k, 0.05 + 0.13 * k);
        n.emplace_back(std::sin(k), std::cos(k), 0.3 * k - 1.0);
    }
    const DenseMatrix all = point_form_factors(s, x, n, 2);
    const DenseMatrix one_thread = point_form_factors(s, x, n, 1);
    CHECK((all - one_thread).cwiseAbs().maxCoeff() == 0.0);
    // Against point_to_polygon_obstructed with every other surface as a blocker.
    for (std::size_t m = 0; m < x.size(); ++m) {
        const DenseMatrix row = point_form_factors(s, {x[m]}, {n[m]});
        CHECK((row.row(0) - all.row(static_cast<Eigen::Index>(m))).cwiseAbs().maxCoeff() == 0.0);
        for (std::size_t j = 0; j < s.patches.size(); j += 5) {
            std::vector<Polygon> blockers;
            for (std::size_t k = 0; k < s.surfaces.size(); ++k)
                if (static_cast<int>(k) != s.patches[j].surface)
                    blockers.push_back(s.surfaces[k].polygon);
            const double ref = point_to_polygon_obstructed(x[m], n[m].normalized(),
                                                           s.patches[j].polygon, blockers);
            CHECK(std::abs(ref - all(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(j))) <
                  1e-13);
        }
    }
}

TEST_CASE("point factors: bad points are errors, an empty list an empty matrix") {
    const Scene s = square_and_blocker(0.25, 0.5);
    CHECK_THROWS_AS(point_form_factors(s, {Vec3(0, 0, 0)}, {}), Error);
    CHECK_THROWS_AS(point_form_factors(s, {Vec3(0, 0, 0)}, {Vec3(0, 0, 0)}), Error);
    CHECK_THROWS_AS(point_form_factors(s, {Vec3(NAN, 0, 0)}, {Vec3(0, 0, 1)}), Error);
    const DenseMatrix F = point_form_factors(s, {}, {});
    CHECK(F.rows() == 0);
    CHECK(F.cols() == 1);
}

TEST_CASE("point factors: back-to-back twin faces, the back of one does not hide the other") {
    // A floor and, 0.5 above it, a thin plate as two one-sided faces (shared/repro/twin_faces.obj).
    const Polygon floor = quad(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0));
    const Polygon up = quad(Vec3(0, 0, 0.5), Vec3(1, 0, 0.5), Vec3(1, 1, 0.5), Vec3(0, 1, 0.5));
    const Polygon down = quad(Vec3(0, 0, 0.5), Vec3(0, 1, 0.5), Vec3(1, 1, 0.5), Vec3(1, 0, 0.5));
    const Scene s = scene_of({floor, up, down});
    // Under the plate's centre, facing up: the unit square at height 0.5 (closed form).
    const double centre = 0.5541264239795719;
    const DenseMatrix below = point_form_factors(s, {Vec3(0.5, 0.5, 0)}, {Vec3(0, 0, 1)});
    CHECK(below(0, 0) == 0.0);
    CHECK(below(0, 1) == 0.0);
    CHECK(std::abs(below(0, 2) - centre) < 1e-14);
    // Above, facing down: the plate's top; the floor is hidden behind it.
    const DenseMatrix above = point_form_factors(s, {Vec3(0.5, 0.5, 1)}, {Vec3(0, 0, -1)});
    CHECK(std::abs(above(0, 1) - centre) < 1e-14);
    CHECK(std::abs(above(0, 0)) < 1e-15);
    CHECK(above(0, 2) == 0.0);
}

TEST_CASE("point factors: normals of any magnitude are normalised without underflow") {
    const Scene s = square_and_blocker(0.15, 0.5);
    const double ref = at_origin_up(s);
    for (const double scale : {1e-200, 1e-160, 1.0, 1e150, 1e300}) {
        CAPTURE(scale);
        const DenseMatrix F = point_form_factors(s, {Vec3(0.5, 0.5, 0)}, {Vec3(0, 0, scale)});
        CHECK(F(0, 0) == ref);
    }
}
