// Polygons with many vertices: an OBJ face of 256 or 1000 vertices is an ordinary
// shape (a disk), read without a limit and handled by every method, subdivision and the
// obstruction machinery. Reference: Howell C-41 (coaxial disks), ../shared/reference.

#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "formfactor/kernels/analytic.h"
#include "formfactor/methods/method.h"
#include "formfactor/methods/point_factors.h"
#include "formfactor/scene/scene.h"
#include "support/files.h"
#include "support/method_runner.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

// C-41 (C-40), r1 = r2 = 1, h = 1: F = (X − sqrt(X² − 4))/2 with X = 3.
constexpr double kDisks = 0.3819660112501051;
// The 256-gons of the catalog (area-matched), ../shared/reference/catalog.json.
constexpr double kDisks256 = 0.38196601088945104;

// An OBJ of two coaxial regular N-gons (area-matched to the unit disk): the emitter at z = 0
// facing +z, the receiver at z = 1 facing −z; with `blocker` a coaxial N-gon of radius
// blocker_radius at z = 0.5 in an obstruction group.
std::string disks_obj(int sides, bool blocker = false, double blocker_radius = 0.5) {
    const double f = std::sqrt(2.0 * kPi / (sides * std::sin(2.0 * kPi / sides)));
    std::string text = "# two coaxial " + std::to_string(sides) + "-gon disks\n";
    auto ring = [&](double r, double z) {
        for (int k = 0; k < sides; ++k) {
            const double t = 2.0 * kPi * k / sides;
            char line[128];
            std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", r * f * std::cos(t),
                          r * f * std::sin(t), z);
            text += line;
        }
    };
    ring(1.0, 0.0);
    ring(1.0, 1.0);
    if (blocker) ring(blocker_radius, 0.5);
    text += "g emitter\nf";
    for (int k = 1; k <= sides; ++k) (text += ' ') += std::to_string(k);
    text += "\ng receiver\nf";  // clockwise seen from +z: faces −z
    for (int k = 0; k < sides; ++k)
        (text += ' ') += std::to_string(sides + 1 + (sides - k) % sides);
    text += "\n";
    if (blocker) {
        text += "g obstruction_disk\nf";
        for (int k = 1; k <= sides; ++k) (text += ' ') += std::to_string(2 * sides + k);
        text += "\n";
    }
    return text;
}

Scene load_disks(int sides, bool blocker = false, double blocker_radius = 0.5) {
    return load_scene(formfactor::testing::write_file(
        "disks" + std::to_string(sides) + (blocker ? "b" : "") + ".obj",
        disks_obj(sides, blocker, blocker_radius)));
}

FormFactors compute(const std::string& method, const Scene& scene, MethodOptions o = {}) {
    nlohmann::json details;
    return run_method(*make_method(method), scene, o, details);
}

}  // namespace

TEST_CASE("large polygons: OBJ faces of 256 and 1000 vertices are read whole") {
    for (const int sides : {255, 256, 1000}) {
        CAPTURE(sides);
        const Scene s = load_disks(sides);
        REQUIRE(s.surfaces.size() == 2);
        CHECK(s.surfaces[0].polygon.size() == static_cast<std::size_t>(sides));
        CHECK(s.surfaces[1].polygon.size() == static_cast<std::size_t>(sides));
        CHECK(s.surfaces[0].where.line == 2 * sides + 3);
        CHECK(s.patches[0].area == doctest::Approx(kPi).epsilon(1e-13));
        CHECK(s.patches[0].normal.z() == doctest::Approx(1.0));
        CHECK(s.patches[1].normal.z() == doctest::Approx(-1.0));
    }
    // A face of 300 vertices after a stand-in keeps later faces, groups and relative indices.
    const Scene b = load_disks(300, true);
    REQUIRE(b.surfaces.size() == 3);
    CHECK(b.surfaces[2].obstruction);
    CHECK(b.surfaces[2].polygon.size() == 300u);
    CHECK(b.surfaces[2].polygon[0].z() == 0.5);
}

TEST_CASE("large polygons: a bad vertex in a long face is still reported with its line") {
    std::string text = disks_obj(400);
    text += "f 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30";
    for (int k = 31; k < 300; ++k) (text += ' ') += std::to_string(k);
    text += " 9999\n";
    const std::string p = formfactor::testing::write_file("bad_long.obj", text);
    const std::string m = formfactor::testing::input_error([&] { load_scene(p); });
    CHECK(m.find("bad_long.obj:" + std::to_string(2 * 400 + 6) + ":") != std::string::npos);
    CHECK(m.find("9999") != std::string::npos);
}

TEST_CASE("large polygons: analytic F between 256-gon and 1000-gon disks against Howell C-41") {
    const FormFactors f256 = compute("analytic", load_disks(256));
    CHECK(std::abs(f256.F(0, 1) - kDisks256) < 1e-12);
    const FormFactors f1000 = compute("analytic", load_disks(1000));
    // Area-matched 1000-gons differ from the disks by ~(2π/N)⁴/… ≈ 3e-13.
    CHECK(std::abs(f1000.F(0, 1) - kDisks) < 2e-11);
    CHECK(std::abs(f1000.F(1, 0) - kDisks) < 2e-11);
    CHECK(f1000.F(0, 0) == 0.0);
}

TEST_CASE("large polygons: subdivision of a 1000-gon tiles it") {
    Scene s = load_disks(1000);
    SubdivisionOptions o;
    o.n = 2;
    subdivide(s, o);
    REQUIRE(s.patches.size() > 2u);
    double a0 = 0.0;
    std::vector<const Polygon*> emitter;
    for (const Patch& p : s.patches)
        if (p.surface == 0) {
            a0 += p.area;
            emitter.push_back(&p.polygon);
        }
    CHECK(a0 == doctest::Approx(kPi).epsilon(1e-12));
    CHECK(emitter.size() == 4u * 998u);  // 998 triangles, 2×2 each
    // Every piece faces the emitter's way and lies on it.
    const double rmax = std::sqrt(2.0 * kPi / (1000 * std::sin(2.0 * kPi / 1000)));
    bool facing = true, on = true;
    for (const Polygon* p : emitter) {
        facing = facing && normal(*p).z() > 1.0 - 1e-12;
        for (const Vec3& v : p->vertices) on = on && v.head<2>().norm() <= rmax * (1 + 1e-12);
    }
    CHECK(facing);
    CHECK(on);
    // --max-edge longer than every edge keeps a surface whole, whatever its vertex count.
    Scene e = load_disks(1000);
    SubdivisionOptions me;
    me.max_edge = 0.5;
    subdivide(e, me);
    CHECK(e.patches.size() == 2u);
    me.max_edge = 0.004;  // the edges are 0.0063 long: every triangle split
    CHECK(subdivision_patch_count(e, me) > 4000.0);
}

TEST_CASE("large polygons: Monte-Carlo methods on 1000-gon disks, within 5 standard errors") {
    const Scene s = load_disks(1000);
    for (const std::string m : {"mc-area", "mc-hemisphere", "mc-target"}) {
        CAPTURE(m);
        MethodOptions o;
        o.samples = 20000;
        const FormFactors ff = compute(m, s, o);
        REQUIRE(ff.standard_error);
        const double se = (*ff.standard_error)(0, 1);
        // mc-target: nothing blocks, se = 0 and F is the exact factor of the polygons, which differ
        // from the disks by ~3e-13.
        CHECK(std::abs(ff.F(0, 1) - kDisks) <= 5.0 * se + 2e-11);
        CHECK(se < 0.01);
    }
}

TEST_CASE("large polygons: hemicube and hemiplane on 1000-gon disks, K points per patch") {
    const Scene s = load_disks(1000);
    MethodOptions o;
    o.resolution = 256;
    for (const std::string m : {"hemicube", "hemiplane"}) {
        CAPTURE(m);
        double previous = 1.0;
        for (const int points : {1, 4, 16}) {
            CAPTURE(points);
            o.points = points;
            nlohmann::json details;
            const FormFactors ff = run_method(*make_method(m), s, o, details);
            // K projections per patch, not one per triangle of the 998 of each disk.
            CHECK(details[m == "hemicube" ? "hemicubes" : "hemiplanes"] == 2 * points);
            // The point-to-area error (the centroid sees 0.447 of the other disk) falls with K;
            // the hemiplane adds its rim band (0.81 % of what it sees).
            const double err = std::abs(ff.F(0, 1) - kDisks);
            CHECK(err < previous);
            previous = err;
        }
        CHECK(previous < (m == "hemicube" ? 2e-2 : 3e-2));
    }
}

TEST_CASE("large polygons: a 1000-gon obstruction disk between 1000-gon disks") {
    // The blocker: radius 0.3 at z = 0.5. From the emitter's centre it hides the receiver's
    // central disk of radius 0.6: F = 1/(1 + 1) − 0.36/(1 + 0.36) (a point below coaxial disks).
    const Scene s = load_disks(1000, true, 0.3);
    const DenseMatrix F = point_form_factors(s, {Vec3(0, 0, 0)}, {Vec3(0, 0, 1)});
    CHECK(std::abs(F(0, 1) - (0.5 - 0.36 / 1.36)) < 1e-9);
    // Two Monte-Carlo estimators of the obstructed F_01 agree within their standard errors, below
    // the unobstructed value.
    MethodOptions o;
    o.samples = 4000;
    const FormFactors t = compute("mc-target", s, o);
    const FormFactors a = compute("mc-area", s, o);
    const double se = std::hypot((*t.standard_error)(0, 1), (*a.standard_error)(0, 1));
    CHECK(std::abs(t.F(0, 1) - a.F(0, 1)) <= 5.0 * se);
    CHECK(t.F(0, 1) < kDisks - 0.03);
}
