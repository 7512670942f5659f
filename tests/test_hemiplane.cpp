#include <doctest/doctest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "formfactor/core/error.h"
#include "formfactor/methods/hemiplane.h"
#include "methods/projection/projection_common.h"
#include "support/lambert.h"
#include "support/method_runner.h"
#include "support/scenes.h"

using formfactor::testing::run_method;

using namespace formfactor;
using namespace formfactor::testing;

namespace {

constexpr double kB3_a1_b1_c1 = 0.13853160599489298;
constexpr double kB3_a10_b10_c1 = 0.24797140829531017;
constexpr double kC11_a1_b1_c1 = 0.19982489569838746;

// The exact form factor of the part of `poly` that the plane [−W, W]² at height 1 sees from x
// (normal n, the plane rotated by `rotation`): Lambert's formula on the polygon clipped to the
// pyramid through the plane's rim.
double through_plane(const Vec3& x, const Vec3& n, double rotation, const Polygon& poly,
                     double W = kHemiplaneHalfWidth) {
    const projection::Frame f = projection::make_frame(x, n, rotation);
    Polygon p = poly;
    for (const Vec3& side : {f.u, Vec3(-f.u), f.v, Vec3(-f.v)}) {
        const Vec3 pn = (W * f.w - side).normalized();
        p = clip_to_front(p, Plane{pn, pn.dot(x)});
        if (p.size() < 3) return 0.0;
    }
    return lambert(x, n, p);
}

FormFactors run(const Scene& s, int R, int K, int threads, nlohmann::json& d) {
    MethodOptions o;
    o.resolution = R;
    o.points = K;
    o.threads = threads;
    return run_method(HemiplaneMethod(), s, o, d);
}

}  // namespace

TEST_CASE("hemiplane: the corner term is Howell B-3, the neglected fraction its complement") {
    CHECK(hemiplane_corner_term(1, 1) == doctest::Approx(kB3_a1_b1_c1).epsilon(1e-14));
    CHECK(hemiplane_corner_term(10, 10) == doctest::Approx(kB3_a10_b10_c1).epsilon(1e-14));
    CHECK(hemiplane_corner_term(-1, 1) == doctest::Approx(-kB3_a1_b1_c1).epsilon(1e-14));
    CHECK(hemiplane_neglected_fraction(10.0) ==
          doctest::Approx(1.0 - 4.0 * kB3_a10_b10_c1).epsilon(1e-12));
    CHECK(hemiplane_neglected_fraction(10.0) == doctest::Approx(0.0081143668).epsilon(1e-8));
    CHECK(hemiplane_neglected_fraction(100.0) < 1e-4);
}

TEST_CASE("hemiplane: delta form factors are exact cell integrals") {
    const Scene cube = load_scene("cube");
    const ProjectionView v = hemiplane_view(cube, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), 64, 0.0, 4);
    double sum = 0.0, centre = 0.0;
    for (int row = 0; row < 64; ++row) {
        for (int col = 0; col < 64; ++col) {
            const double d = v.delta[static_cast<std::size_t>(row) * 64 + col];
            sum += d;
            if (row >= 16 && row < 48 && col >= 16 && col < 48) centre += d;
        }
    }
    CHECK(sum == doctest::Approx(1.0 - v.neglected).epsilon(1e-12));
    // The central 32 × 32 cells are the square [−5, 5]².
    CHECK(centre == doctest::Approx(4.0 * hemiplane_corner_term(5, 5)).epsilon(1e-12));
}

TEST_CASE("hemiplane: points see within the stated bound of the exact values") {
    // |F − exact part through the plane| ≤ the ambiguous fraction (finest cells decided by
    // their centre); the part beyond the rim is ≤ the neglected fraction.
    const Polygon b3 = Polygon{{Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1), Vec3(0, 0, 1)}};
    const Polygon b3w = Polygon{{Vec3(0, 10, 1), Vec3(10, 10, 1), Vec3(10, 0, 1), Vec3(0, 0, 1)}};
    const Polygon b4 = Polygon{{Vec3(0, 1, 0), Vec3(1, 1, 0), Vec3(1, 1, 1), Vec3(0, 1, 1)}};
    const Polygon tri{{Vec3(0.2, -0.3, 1.0), Vec3(-0.8, -0.6, 0.7), Vec3(-0.5, 0.9, 1.4)}};
    for (const Polygon& poly : {b3, b3w, b4, tri}) {
        const Scene s = scene_of({poly});
        const double full = lambert(Vec3::Zero(), Vec3::UnitZ(), poly);
        for (double rot : {0.0, 0.3, 1.1}) {
            const HemiplaneRow r = hemiplane_point_row(s, Vec3::Zero(), Vec3::UnitZ(), 256, rot);
            const double seen = through_plane(Vec3::Zero(), Vec3::UnitZ(), rot, poly);
            CAPTURE(rot);
            CAPTURE(full);
            CHECK(std::abs(r.F[0] - seen) <= r.ambiguous + 1e-12);
            CHECK(full - seen <= r.neglected);
            CHECK(full - seen >= -1e-12);
            // In practice the centre rule does far better than the bound, but the plane's
            // cells are 20/256 = 0.078 height units wide: straight edges alias coherently,
            // a few 1e-3 here (the hemicube's top cells are 10× finer).
            CHECK(std::abs(r.F[0] - seen) < 1e-2);
        }
    }
    CHECK(through_plane(Vec3::Zero(), Vec3::UnitZ(), 0.0, b3) ==
          doctest::Approx(kB3_a1_b1_c1).epsilon(1e-12));
}

TEST_CASE("hemiplane: the error falls as the resolution grows (R = 64, 128, 256, 512)") {
    const Polygon tri{{Vec3(0.2, -0.3, 1.0), Vec3(-0.8, -0.6, 0.7), Vec3(-0.5, 0.9, 1.4)}};
    const Scene s = scene_of({tri});
    const Vec3 x(0.1, 0.05, 0.0);
    std::vector<double> err, amb;
    for (int R : {64, 128, 256, 512}) {
        double e = 0.0, a = 0.0;
        for (int k = 0; k < 8; ++k) {
            const HemiplaneRow r = hemiplane_point_row(s, x, Vec3::UnitZ(), R, 0.7 * k);
            e += std::abs(r.F[0] - through_plane(x, Vec3::UnitZ(), 0.7 * k, tri));
            a += r.ambiguous;
        }
        err.push_back(e / 8.0);
        amb.push_back(a / 8.0);
        MESSAGE("hemiplane R = " << R << ": mean |error| = " << e / 8.0
                                 << ", ambiguous (bound) = " << a / 8.0);
    }
    for (std::size_t k = 1; k < amb.size(); ++k) CHECK(amb[k] < 0.6 * amb[k - 1]);  // ~1/R
    CHECK(err.back() < err.front() / 4.0);
}

TEST_CASE("hemiplane: plates (C-11) with 16 points") {
    const Scene pl = load_scene("plates");
    nlohmann::json d;
    const auto F = run(pl, 512, 16, 0, d).F;
    // The plates lie well inside the plane (nothing near the horizon): the error is the
    // discretisation only, bounded by the ambiguous fraction; in practice ~1e-4.
    CHECK(std::abs(F(0, 1) - kC11_a1_b1_c1) <= d["ambiguous_max"].get<double>());
    CHECK(std::abs(F(0, 1) - kC11_a1_b1_c1) < 5e-4);
    CHECK(d["neglected_fraction"].get<double>() == doctest::Approx(0.0081143668).epsilon(1e-8));
}

TEST_CASE("hemiplane: rows of the closed cube sum to 1 − the neglected fraction") {
    Scene cube = load_scene("cube");
    subdivide(cube, SubdivisionOptions{3, 0.0});
    nlohmann::json d;
    const auto F = run(cube, 128, 1, 0, d).F;
    const double neglected = d["neglected_fraction"].get<double>();
    for (Eigen::Index i = 0; i < F.rows(); ++i) {
        CHECK(F.row(i).sum() == doctest::Approx(1.0 - neglected).epsilon(1e-12));
    }
}

TEST_CASE("hemiplane: item buffer at the centre of the cube's floor") {
    const Scene cube = load_scene("cube");
    const int R = 64;  // cells of 20/64 = 0.3125 height units
    const ProjectionView v = hemiplane_view(cube, Vec3(0.5, 0.5, 0), Vec3::UnitZ(), R, 0.0, 4);
    REQUIRE(v.width == R);
    // The ceiling spans [−1/2, 1/2]²: cells 30..33 straddle its edge, 31 and 32 are inside.
    CHECK(v.item(31, 31) == 5);
    CHECK(v.item(32, 32) == 5);
    CHECK(v.item(31, 32) == 5);
    for (int row = 0; row < R; ++row) {
        for (int col = 0; col < R; ++col) {
            const int item = v.item(col, row);
            CHECK(item >= 0);
            CHECK(item <= 5);
            CHECK(item != 4);
            if (col < 30 || col > 33 || row < 30 || row > 33) CHECK(item != 5);
        }
    }
}

TEST_CASE("hemiplane: the thread count never changes a result") {
    Scene s = load_scene("cornell");
    subdivide(s, SubdivisionOptions{2, 0.0});
    nlohmann::json d;
    const auto F1 = run(s, 64, 2, 1, d).F;
    const auto F2 = run(s, 64, 2, 2, d).F;
    CHECK((F1.array() == F2.array()).all());
}

TEST_CASE("hemiplane: options are checked") {
    const Scene pl = load_scene("plates");
    nlohmann::json d;
    CHECK_THROWS_AS(run(pl, 96, 1, 1, d), OptionError);  // not a power of two
    CHECK_THROWS_AS(run(pl, 4096, 1, 1, d), OptionError);
    CHECK_THROWS_AS(run(pl, 64, 0, 1, d), OptionError);
    CHECK_THROWS_AS(HemiplaneMethod(-1.0).check(pl), OptionError);
    CHECK(make_method("hemiplane")->name() == "hemiplane");
}
