#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "formfactor/core/error.h"
#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/hemicube.h"
#include "support/lambert.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;
using namespace formfactor::testing;

namespace {

// Reference values (Howell's catalog, copied from shared/reference/catalog.json).
constexpr double kB3_a1_b1_c1 = 0.13853160599489298;
constexpr double kB3_a10_b10_c1 = 0.24797140829531017;
constexpr double kB4_a1_b1_c1 = 0.05573419700255351;
constexpr double kC11_a1_b1_c1 = 0.19982489569838746;  // plates; the cube's opposite faces
constexpr double kC14_l1_w1_h1 = 0.20004377607540316;  // the cube's adjacent faces

FormFactors run(const Scene& s, int R, int K = 1, int threads = 0, std::uint64_t seed = 1) {
    MethodOptions o;
    o.resolution = R;
    o.points = K;
    o.threads = threads;
    o.seed = seed;
    nlohmann::json details;
    return run_method(HemicubeMethod(), s, o, details);
}

Polygon rect_b3(double a, double b, double c) {
    return Polygon{{Vec3(0, b, c), Vec3(a, b, c), Vec3(a, 0, c), Vec3(0, 0, c)}};
}

}  // namespace

TEST_CASE("hemicube: delta form factors sum to 1, each face holding its analytic share") {
    const int R = 256;
    const std::vector<double> d = hemicube_delta_form_factors(R);
    REQUIRE(d.size() == 3u * R * R);
    double total = 0.0, top = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) {
        total += d[k];
        if (k < static_cast<std::size_t>(R) * R) top += d[k];
    }
    CHECK(total == doctest::Approx(1.0).epsilon(1e-13));
    // The top face is the square [−1, 1]² at height 1: 4 × Howell B-3 (a = b = c = 1). The
    // midpoint rule errs by O(1/R²) before the normalisation.
    CHECK(std::abs(top - 4.0 * kB3_a1_b1_c1) < 1e-5);
    CHECK_THROWS_AS(hemicube_delta_form_factors(63), OptionError);
    CHECK_THROWS_AS(hemicube_delta_form_factors(66 + 1), OptionError);
    CHECK_THROWS_AS(hemicube_delta_form_factors(4096), OptionError);
    CHECK_NOTHROW(hemicube_delta_form_factors(66));
}

TEST_CASE("hemicube: a point to a rectangle matches Howell B-3 and B-4") {
    const Scene b3 = scene_of({rect_b3(1, 1, 1)});
    const Scene b3w = scene_of({rect_b3(10, 10, 1)});
    const Scene b4 =
        scene_of({Polygon{{Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1)}}});
    // Aliasing: misassigned cells lie along the projected outline; at R = 256 their share is a
    // few 1e-5 for the horizontal rectangles (oblique edges on the top face average out).
    for (double rot : {0.0, 0.3, 1.1}) {
        CAPTURE(rot);
        CHECK(std::abs(hemicube_point_row(b3, Vec3::Zero(), Vec3::UnitZ(), 256, rot)[0] -
                       kB3_a1_b1_c1) < 5e-5);
        CHECK(std::abs(hemicube_point_row(b3w, Vec3::Zero(), Vec3::UnitZ(), 256, rot)[0] -
                       kB3_a10_b10_c1) < 2e-4);
        // The wall's vertical edges project onto the side faces parallel to the cell columns,
        // so their aliasing is coherent: up to half a column of side cells per edge, ~4e-4 at
        // R = 256 (it vanishes at rot = 0, where the edges fall on cell boundaries).
        CHECK(std::abs(hemicube_point_row(b4, Vec3::Zero(), Vec3::UnitZ(), 256, rot)[0] -
                       kB4_a1_b1_c1) < 5e-4);
    }
}

TEST_CASE("hemicube: the error falls as the resolution grows (R = 64, 128, 256, 512)") {
    // A tilted triangle seen from an off-axis point, exact by Lambert's formula; the mean
    // absolute error over 8 rotations of the cube, per resolution.
    const Polygon tri{{Vec3(0.2, -0.3, 1.0), Vec3(-0.8, -0.6, 0.7), Vec3(-0.5, 0.9, 1.4)}};
    const Scene s = scene_of({tri});
    const Vec3 x(0.1, 0.05, 0.0);
    const double exact = lambert(x, Vec3::UnitZ(), tri);
    std::vector<double> err;
    for (int R : {64, 128, 256, 512}) {
        double e = 0.0;
        for (int k = 0; k < 8; ++k) {
            e += std::abs(hemicube_point_row(s, x, Vec3::UnitZ(), R, 0.7 * k)[0] - exact);
        }
        err.push_back(e / 8.0);
        MESSAGE("hemicube R = " << R << ": mean |error| = " << e / 8.0 << " (F = " << exact << ")");
    }
    for (std::size_t k = 1; k < err.size(); ++k) CHECK(err[k] < err[k - 1]);
    CHECK(err.back() < err.front() / 4.0);
    CHECK(err.back() < 2e-5);
}

TEST_CASE("hemicube: the cube's opposite and adjacent faces (C-11, C-14)") {
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{4, 0.0});
    REQUIRE(cube.patches.size() == 96u);
    // Surfaces: x0, x1, y0, y1, z0, z1.
    SUBCASE("4 × 4 patches per face, one point each, R = 512: within 2e-3") {
        // Dominated by the point-to-area error of one point per patch (the midpoint rule on
        // a 4 × 4 grid: 1.9e-3 for opposite faces); aliasing is below 1e-4.
        const auto F = run(cube, 512, 1).F;
        CHECK(std::abs(surface_factor(cube, F, 0, 1) - kC11_a1_b1_c1) < 2e-3);
        CHECK(std::abs(surface_factor(cube, F, 0, 2) - kC14_l1_w1_h1) < 2e-3);
        CHECK(std::abs(surface_factor(cube, F, 4, 5) - kC11_a1_b1_c1) < 2e-3);
    }
    SUBCASE("4 Gauss points per patch, R = 256: within 2e-4") {
        const auto F = run(cube, 256, 4).F;
        CHECK(std::abs(surface_factor(cube, F, 0, 1) - kC11_a1_b1_c1) < 2e-4);
        CHECK(std::abs(surface_factor(cube, F, 0, 2) - kC14_l1_w1_h1) < 2e-4);
    }
}

TEST_CASE("hemicube: plates with 16 points are within 1e-4 of C-11") {
    const Scene pl = load_scene("plates");
    // The 4 × 4 Gauss rule's point-to-area error is 1.5e-6; aliasing at R = 256 a few 1e-5.
    for (std::uint64_t seed : {1u, 2u, 3u}) {
        const auto F = run(pl, 256, 16, 0, seed).F;
        CHECK(std::abs(F(0, 1) - kC11_a1_b1_c1) < 1e-4);
        CHECK(std::abs(F(1, 0) - kC11_a1_b1_c1) < 1e-4);
        CHECK(F(0, 0) == 0.0);
    }
}

TEST_CASE("hemicube: rows of a closed enclosure sum to 1") {
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{4, 0.0});
    const auto F = run(cube, 256, 1).F;
    // Every cell of every hemicube sees a patch and the delta form factors sum to 1; what is
    // left is the single-precision rounding of the delta form factors.
    for (Eigen::Index i = 0; i < F.rows(); ++i) CHECK(std::abs(F.row(i).sum() - 1.0) < 1e-6);
    CHECK(F.minCoeff() >= 0.0);
}

TEST_CASE("hemicube: item buffer at the centre of the cube's floor") {
    const Scene cube = load_scene("cube");  // x0, x1, y0, y1, z0 (floor), z1 (ceiling)
    const int R = 64;
    const ProjectionView v = hemicube_view(cube, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), R, 0.0, 4);
    REQUIRE(v.width == 2 * R);
    REQUIRE(v.height == 2 * R);
    // The top face (the middle R × R) sees the ceiling where |u|, |v| < 1/2 (the ceiling at
    // height 1 spans [−1/2, 1/2]² in units of the height), walls elsewhere.
    int ceiling = 0;
    for (int row = R / 2; row < 3 * R / 2; ++row) {
        for (int col = R / 2; col < 3 * R / 2; ++col) {
            const bool centre =
                col >= 3 * R / 4 && col < 5 * R / 4 && row >= 3 * R / 4 && row < 5 * R / 4;
            const int item = v.item(col, row);
            if (centre) {
                CHECK(item == 5);
                ++ceiling;
            } else {
                CHECK((item >= 0 && item <= 3));
            }
        }
    }
    CHECK(ceiling == R * R / 4);
    // Each arm of the cross (a side face) sees one wall, entirely, and the four are distinct;
    // a wall continues from the arm into the top face (the unfolding is continuous).
    std::set<int> walls;
    const int arm_item[4] = {v.item(2 * R - 1, R), v.item(0, R), v.item(R, 0),
                             v.item(R, 2 * R - 1)};
    for (int a : arm_item) walls.insert(a);
    CHECK(walls == std::set<int>{0, 1, 2, 3});
    for (int row = R / 2; row < 3 * R / 2; ++row) {
        for (int col = 3 * R / 2; col < 2 * R; ++col) CHECK(v.item(col, row) == arm_item[0]);
        for (int col = 0; col < R / 2; ++col) CHECK(v.item(col, row) == arm_item[1]);
    }
    CHECK(v.item(3 * R / 2 - 1, R) == arm_item[0]);  // top face, just inside its right edge
    CHECK(v.item(R / 2, R) == arm_item[1]);
    CHECK(v.item(R, R / 2) == arm_item[2]);
    CHECK(v.item(R, 3 * R / 2 - 1) == arm_item[3]);
    // Corners of the cross are no cells; the ceiling's delta form factors add up to the
    // exact point value 4 G(1/2, 1/2) (Howell B-3) up to the midpoint rule.
    CHECK(v.item(0, 0) == kViewUnused);
    double f_ceiling = 0.0, f_all = 0.0;
    for (std::size_t k = 0; k < v.items.size(); ++k) {
        if (v.items[k] == 5) f_ceiling += v.delta[k];
        f_all += v.delta[k];
        CHECK(v.items[k] != kViewNothing);
    }
    CHECK(f_all == doctest::Approx(1.0).epsilon(1e-12));
    CHECK(std::abs(f_ceiling - 0.23945647046077350) < 1e-4);
}

TEST_CASE("hemicube: an obstruction between the plates hides what it covers") {
    // A square blocker [3/8, 5/8]² at height 1/2 seen from the centre of the bottom plate
    // covers the same directions as [1/4, 3/4]² at height 1: F drops by exactly its own
    // (Lambert) form factor.
    const Polygon blocker{{Vec3(0.375, 0.375, 0.5), Vec3(0.625, 0.375, 0.5),
                           Vec3(0.625, 0.625, 0.5), Vec3(0.375, 0.625, 0.5)}};
    const Scene open = scene_of(plates());
    const Scene blocked = scene_of(plates(), {blocker});
    const Vec3 x(0.5, 0.5, 0.0);
    const double f_open = lambert(x, Vec3::UnitZ(), plates()[1]);
    const double f_blocked = f_open - lambert(x, Vec3::UnitZ(), blocker);
    // Howell B-3: 4 G(1/2, 1/2) − 4 G(1/4, 1/4).
    CHECK(f_blocked == doctest::Approx(0.2394564704607735 - 0.07347763481252137).epsilon(1e-12));
    for (double rot : {0.0, 0.4}) {
        // Two outlines alias now: the plate's and the blocker's.
        CHECK(std::abs(hemicube_point_row(open, x, Vec3::UnitZ(), 256, rot, 0)[1] - f_open) < 1e-4);
        CHECK(std::abs(hemicube_point_row(blocked, x, Vec3::UnitZ(), 256, rot, 0)[1] - f_blocked) <
              2e-4);
    }
    // The blocker is obstruction-only: it owns no column, and the matrix stays 2 × 2.
    const auto F = run(blocked, 128, 4).F;
    CHECK(F.rows() == 2);
    CHECK(F(0, 1) < run(open, 128, 4).F(0, 1) - 0.02);
}

TEST_CASE("hemicube: back faces block but earn nothing") {
    // The top plate turned to face up: the bottom plate sees its back, F = 0; a third plate
    // above it, facing down, is hidden behind that back face.
    const Polygon bottom = plates()[0];
    const Polygon top_up{{Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 1)}};
    const Polygon high{{Vec3(0, 0, 2), Vec3(0, 1, 2), Vec3(1, 1, 2), Vec3(1, 0, 2)}};
    const Scene s = scene_of({bottom, top_up, high});
    const auto row = hemicube_point_row(s, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 128, 0.0, 0);
    CHECK(row[1] == 0.0);
    CHECK(row[2] == 0.0);
    const ProjectionView v = hemicube_view(s, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 128, 0.0, 0);
    CHECK(v.item(128, 128) == kViewBackFace);
}

TEST_CASE("hemicube: the thread count never changes a result") {
    Scene s = load_scene("cornell");
    subdivide(s, SubdivisionOptions{2, 0.0});
    const auto F1 = run(s, 64, 4, 1, 7).F;
    const auto F2 = run(s, 64, 4, 2, 7).F;
    CHECK((F1.array() == F2.array()).all());
    // A different seed rotates the hemicubes differently.
    CHECK_FALSE((run(s, 64, 4, 2, 8).F.array() == F1.array()).all());
}

TEST_CASE("hemicube: options are checked") {
    const Scene pl = load_scene("plates");
    MethodOptions o;
    nlohmann::json d;
    HemicubeMethod m;
    o.resolution = 255;
    CHECK_THROWS_AS(run_method(m, pl, o, d), OptionError);
    o.resolution = 32;
    CHECK_THROWS_AS(run_method(m, pl, o, d), OptionError);
    o.resolution = 64;
    o.points = 0;
    CHECK_THROWS_AS(run_method(m, pl, o, d), OptionError);
    o.points = 1;
    CHECK_NOTHROW(run_method(m, pl, o, d));
    CHECK(d["resolution"] == 64);
    CHECK(make_method("hemicube")->name() == "hemicube");
}

TEST_CASE("hemicube: non-convex and many-sided patches") {
    // An L-shaped ceiling (6 vertices, non-convex: triangulated) and a 12-gon (convex but more
    // than 8 vertices: triangulated), both facing down at height 1; exact by Lambert's formula
    // (the L as two rectangles).
    const Polygon ell{{Vec3(-0.5, -0.5, 1), Vec3(-0.5, 1, 1), Vec3(0, 1, 1), Vec3(0, 0, 1),
                       Vec3(1, 0, 1), Vec3(1, -0.5, 1)}};
    const double f_ell =
        lambert(Vec3::Zero(), Vec3::UnitZ(),
                Polygon{{Vec3(-0.5, -0.5, 1), Vec3(0, -0.5, 1), Vec3(0, 1, 1), Vec3(-0.5, 1, 1)}}) +
        lambert(Vec3::Zero(), Vec3::UnitZ(),
                Polygon{{Vec3(0, -0.5, 1), Vec3(1, -0.5, 1), Vec3(1, 0, 1), Vec3(0, 0, 1)}});
    Polygon gon;
    for (int k = 0; k < 12; ++k) {
        const double a = -2.0 * kPi * k / 12.0;  // clockwise seen from above: faces down
        gon.vertices.push_back(Vec3(0.3 + 0.6 * std::cos(a), 0.6 * std::sin(a), 1.5));
    }
    const Scene s = scene_of({ell});
    const Scene g = scene_of({gon});
    for (double rot : {0.0, 0.5}) {
        CHECK(std::abs(hemicube_point_row(s, Vec3::Zero(), Vec3::UnitZ(), 256, rot)[0] - f_ell) <
              2e-4);
        CHECK(std::abs(hemicube_point_row(g, Vec3::Zero(), Vec3::UnitZ(), 256, rot)[0] -
                       lambert(Vec3::Zero(), Vec3::UnitZ(), gon)) < 1e-4);
    }
    // Several points on the L: the row is still a weighted mean (reciprocity with a floor).
    Scene box = scene_of({plates()[0], ell});
    const auto F = run(box, 128, 9).F;
    CHECK(F(0, 1) * 1.0 == doctest::Approx(F(1, 0) * area(ell)).epsilon(0.01));
}

TEST_CASE("hemicube: a blocker between the plates, area to area, against the analytic method") {
    // Blocker [3/8, 5/8]² at height 1/2. From x on the bottom plate its shadow on the top
    // plate is the square [3/4 − x, 5/4 − x] (per coordinate) clipped to [0, 1]², so the exact
    // F = ∫ (F_{x→top} − F_{x→shadow}) dx / A, with exact point values (point_to_polygon) and
    // a composite Gauss rule split where the shadow meets the plate's edges (x = 1/4, 3/4).
    const Polygon blocker{{Vec3(0.375, 0.375, 0.5), Vec3(0.625, 0.375, 0.5),
                           Vec3(0.625, 0.625, 0.5), Vec3(0.375, 0.625, 0.5)}};
    const Polygon top = plates()[1];
    const double g[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                         0.8611363115940526};
    const double gw[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                          0.3478548451374538};
    const double cuts[4] = {0.0, 0.25, 0.75, 1.0};
    std::vector<std::pair<double, double>> nodes;  // (x, weight) on [0, 1]
    for (int c = 0; c < 3; ++c) {
        const double a = cuts[c], b = cuts[c + 1];
        for (int k = 0; k < 4; ++k)
            nodes.push_back({0.5 * (a + b) + 0.5 * (b - a) * g[k], 0.5 * (b - a) * gw[k]});
    }
    double exact = 0.0;
    for (const auto& [x, wx] : nodes) {
        for (const auto& [y, wy] : nodes) {
            const double x0 = std::max(0.0, 0.75 - x), x1 = std::min(1.0, 1.25 - x);
            const double y0 = std::max(0.0, 0.75 - y), y1 = std::min(1.0, 1.25 - y);
            const Polygon shadow{
                {Vec3(x0, y0, 1), Vec3(x0, y1, 1), Vec3(x1, y1, 1), Vec3(x1, y0, 1)}};
            const Vec3 p(x, y, 0);
            exact += wx * wy *
                     (point_to_polygon(p, Vec3::UnitZ(), top) -
                      point_to_polygon(p, Vec3::UnitZ(), shadow));
        }
    }
    const Scene blocked = scene_of(plates(), {blocker});
    const auto F = run(blocked, 256, 64).F;
    CHECK(exact < kC11_a1_b1_c1 - 0.02);  // the blocker takes a sixth of the exchange
    // 8 × 8 Gauss points ignore the kinks of the integrand: that, not aliasing, is most of
    // the 2e-4 left.
    CHECK(std::abs(F(0, 1) - exact) < 1e-3);
    CHECK(std::abs(F(1, 0) - exact) < 1e-3);
}

TEST_CASE("hemicube: the subdivided cube against the analytic method, entry by entry") {
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{3, 0.0});
    MethodOptions o;
    nlohmann::json d;
    const auto exact = run_method(*make_method("analytic"), cube, o, d).F;
    const auto F = run(cube, 256, 9).F;
    const double worst = (F - exact).cwiseAbs().maxCoeff();
    MESSAGE("cube 3×3 per face, R = 256, 9 points: max |F − exact| = " << worst);
    // Neighbours across an edge carry the largest point-to-area error (F_{dA→Aj} varies
    // fastest there); with 3 × 3 Gauss points the worst entry is 2e-4.
    CHECK(worst < 1e-3);
}
