#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {
const Surface& by_name(const Scene& s, const std::string& name) {
    for (const Surface& x : s.surfaces)
        if (x.name == name) return x;
    FAIL("no surface " << name);
    return s.surfaces.front();
}
// Volume-weighted test of "faces inward": the centroid of the box lies in front of the face.
bool faces_point(const Surface& s, const Vec3& p) {
    return plane_of(s.polygon).signed_distance(p) > 0.0;
}
}  // namespace

TEST_CASE("scene: builtin names and dispatch") {
    const auto names = builtin_scene_names();
    CHECK(names.size() == 5);
    for (const std::string& n : names) {
        CHECK(is_builtin_scene(n));
        const Scene s = load_scene(n);  // names win over extensions
        CHECK(s.name == n);
        CHECK(s.patches.size() == s.surfaces.size() - s.obstruction_count());
        for (std::size_t k = 0; k < s.surfaces.size(); ++k) {
            CHECK_NOTHROW(validate_polygon(s.surfaces[k].polygon, {n, 0}, "s"));
            CHECK(s.surfaces[k].material >= 0);
            CHECK(static_cast<std::size_t>(s.surfaces[k].material) < s.materials.size());
        }
    }
    CHECK_FALSE(is_builtin_scene("cornell.obj"));
}

TEST_CASE("scene: cube is closed, unit faces inward, area 6, documented order") {
    const Scene s = builtin_scene("cube");
    CHECK(s.enclosure);
    REQUIRE(s.surfaces.size() == 6);
    CHECK(s.total_patch_area() == doctest::Approx(6.0).epsilon(1e-15));
    const Vec3 expected[6] = {Vec3(1, 0, 0),  Vec3(-1, 0, 0), Vec3(0, 1, 0),
                              Vec3(0, -1, 0), Vec3(0, 0, 1),  Vec3(0, 0, -1)};
    for (std::size_t k = 0; k < 6; ++k) {
        CHECK((s.patches[k].normal - expected[k]).norm() < 1e-15);
        CHECK(s.patches[k].area == doctest::Approx(1.0).epsilon(1e-15));
        CHECK(faces_point(s.surfaces[k], Vec3(0.5, 0.5, 0.5)));
    }
    const Bounds3 b = s.bounds();
    CHECK((b.lo - Vec3::Zero()).norm() == 0.0);
    CHECK((b.hi - Vec3::Ones()).norm() == 0.0);
}

TEST_CASE("scene: plates and perpendicular face each other") {
    const Scene p = builtin_scene("plates");
    REQUIRE(p.patches.size() == 2);
    CHECK((p.patches[0].normal - Vec3(0, 0, 1)).norm() < 1e-15);
    CHECK((p.patches[1].normal - Vec3(0, 0, -1)).norm() < 1e-15);
    CHECK(p.patches[0].area == 1.0);
    CHECK(p.patches[1].area == 1.0);
    CHECK(p.patches[1].centroid.z() == 1.0);
    const Scene q = builtin_scene("perpendicular");
    REQUIRE(q.patches.size() == 2);
    CHECK((q.patches[0].normal - Vec3(0, 0, 1)).norm() < 1e-15);
    CHECK((q.patches[1].normal - Vec3(0, 1, 0)).norm() < 1e-15);
    // Each lies in front of the other.
    CHECK(plane_of(q.surfaces[0].polygon).signed_distance(q.patches[1].centroid) > 0);
    CHECK(plane_of(q.surfaces[1].polygon).signed_distance(q.patches[0].centroid) > 0);
    // They share the edge x ∈ [0, 1] at y = z = 0.
    CHECK(q.surfaces[0].polygon[0] == q.surfaces[1].polygon[0]);
    CHECK(q.surfaces[0].polygon[1] == q.surfaces[1].polygon[3]);
}

TEST_CASE("scene: Cornell box walls face inward, blocks outward, light down") {
    const Scene s = builtin_scene("cornell");
    const Scene e = builtin_scene("cornell-empty");
    CHECK(s.surfaces.size() == 20);
    CHECK(e.surfaces.size() == 10);
    REQUIRE(s.camera.has_value());
    CHECK((s.camera->eye - Vec3(278, 273, -800)).norm() == 0.0);
    CHECK((s.camera->target - Vec3(278, 273, -799)).norm() == 0.0);
    CHECK(s.camera->fov_degrees ==
          doctest::Approx(2.0 * std::atan(12.5 / 35.0) * 180.0 / kPi).epsilon(1e-12));
    const Vec3 inside(278, 274.4, 279.6);
    for (const char* w : {"floor", "ceiling.front", "ceiling.back", "ceiling.left", "ceiling.right",
                          "light", "back", "right", "left.1", "left.2"})
        CHECK_MESSAGE(faces_point(by_name(s, w), inside), w);
    CHECK((normal(by_name(s, "floor").polygon) - Vec3(0, 1, 0)).norm() < 1e-15);
    CHECK((normal(by_name(s, "light").polygon) - Vec3(0, -1, 0)).norm() < 1e-15);
    CHECK((normal(by_name(s, "right").polygon) - Vec3(1, 0, 0)).norm() < 1e-15);
    CHECK((normal(by_name(s, "back").polygon) - Vec3(0, 0, -1)).norm() < 1e-15);
    // The light is 130 × 105 mm and emits; the ceiling pieces plus the light tile 556 × 559.2.
    const Surface& light = by_name(s, "light");
    CHECK(area(light.polygon) == doctest::Approx(130.0 * 105.0).epsilon(1e-14));
    CHECK(s.materials[static_cast<std::size_t>(light.material)].emission.maxCoeff() > 0.0);
    double ceiling = area(light.polygon);
    for (const char* c : {"ceiling.front", "ceiling.back", "ceiling.left", "ceiling.right"})
        ceiling += area(by_name(s, c).polygon);
    CHECK(ceiling == doctest::Approx(556.0 * 559.2).epsilon(1e-14));
    // Colours: red left wall, green right wall.
    CHECK(s.materials[static_cast<std::size_t>(by_name(s, "left.1").material)].reflectance.x() ==
          0.63);
    CHECK(s.materials[static_cast<std::size_t>(by_name(s, "right").material)].reflectance.y() ==
          0.45);
    // Blocks: 5 faces each, facing away from their own centre.
    const Vec3 short_c(186, 82.5, 169), tall_c(368.5, 165, 351.25);
    for (const char* f : {"short.top", "short.1", "short.2", "short.3", "short.4"})
        CHECK_MESSAGE(!faces_point(by_name(s, f), short_c), f);
    for (const char* f : {"tall.top", "tall.1", "tall.2", "tall.3", "tall.4"})
        CHECK_MESSAGE(!faces_point(by_name(s, f), tall_c), f);
    // The blocks' footprints: short block top is 165 above the floor, tall 330.
    CHECK(by_name(s, "short.top").polygon[0].y() == 165.0);
    CHECK(by_name(s, "tall.top").polygon[0].y() == 330.0);
    CHECK(e.obstruction_count() == 0);
    CHECK_FALSE(s.enclosure);
}

TEST_CASE("scene: material_of a patch goes through its surface, with a default") {
    Scene s = load_scene("cornell");
    bool emitting = false;
    for (std::size_t i = 0; i < s.patches.size(); ++i) {
        const auto surface = static_cast<std::size_t>(s.patches[i].surface);
        CHECK(&s.material_of(i) == &s.material_of_surface(surface));
        emitting = emitting || s.material_of(i).emission.maxCoeff() > 0.0;
    }
    CHECK(emitting);  // the light
    CHECK(s.material_of(s.patches.size()).emissivity == 0.9);
    s.surfaces[0].material = 1000;  // no such entry: the default
    CHECK(s.material_of_surface(0).name == "default");
}
