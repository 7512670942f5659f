// The city-N generator (formfactor/scene/city.h): patch count, orientation, no overlaps.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/city.h"
#include "formfactor/scene/scene.h"

using namespace formfactor;

namespace {

// The axis-aligned box of a patch.
Bounds3 box_of(const Patch& p) {
    Bounds3 b;
    for (const Vec3& v : p.polygon.vertices) b.extend(v);
    return b;
}

// Area of the overlap of two boxes in the plane spanned by the axes other than `axis`.
double overlap_area(const Bounds3& a, const Bounds3& b, int axis) {
    double area = 1.0;
    for (int c = 0; c < 3; ++c) {
        if (c == axis) continue;
        area *= std::max(0.0, std::min(a.hi[c], b.hi[c]) - std::max(a.lo[c], b.lo[c]));
    }
    return area;
}

int normal_axis(const Vec3& n) {
    int axis = 0;
    n.cwiseAbs().maxCoeff(&axis);
    return axis;
}

}  // namespace

TEST_CASE("city: patch count follows the documented formula") {
    for (int n : {1, 2, 3, 4, 6}) {
        CAPTURE(n);
        const Scene s = city_scene(n);
        CHECK(s.patches.size() == city_patch_count(n));
        std::size_t walls = 0;
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) walls += 8 * std::size_t(city_building_height(x, y));
        const auto m = std::size_t(n);
        CHECK(s.patches.size() == (m + 1) * (5 * m + 1) + 4 * m * m + walls);
        if (n % 2 == 0) CHECK(s.patches.size() == 29 * m * m + 6 * m + 1);
        CHECK(s.surfaces.size() == s.patches.size());  // a surface per unit patch
        CHECK_FALSE(s.enclosure);
        CHECK(s.name == "city-" + std::to_string(n));
        for (const Patch& p : s.patches) CHECK(p.area == doctest::Approx(1.0).epsilon(1e-12));
    }
    CHECK(city_patch_count(6) == 1081);
    CHECK(city_patch_count(18) == 9505);
    CHECK(city_patch_count(58) == 97905);
}

TEST_CASE("city: ground and roofs face up and walls face out of their building") {
    const Scene s = city_scene(3);
    for (const Patch& p : s.patches) {
        const std::string& name = s.surfaces[std::size_t(p.surface)].name;
        CAPTURE(name);
        CHECK(std::abs(p.normal.norm() - 1.0) < 1e-12);
        if (name.rfind("ground", 0) == 0) {
            CHECK(p.normal.z() == doctest::Approx(1.0));
            CHECK(std::abs(p.centroid.z()) < 1e-12);
        } else if (name.rfind("roof", 0) == 0) {
            CHECK(p.normal.z() == doctest::Approx(1.0));
            CHECK(p.centroid.z() >= 1.0);
        } else {
            REQUIRE(name.rfind("wall", 0) == 0);
            CHECK(std::abs(p.normal.z()) < 1e-12);
            // The building whose footprint [3x+1, 3x+3] × [3y+1, 3y+3] the wall bounds.
            const double bx = 3.0 * std::floor((p.centroid.x() - 1.0 + 1e-9) / 3.0) + 2.0;
            const double by = 3.0 * std::floor((p.centroid.y() - 1.0 + 1e-9) / 3.0) + 2.0;
            const Vec3 out = p.centroid - Vec3(bx, by, p.centroid.z());
            CHECK(out.dot(p.normal) == doctest::Approx(1.0));  // 1 from the centre, outward
        }
    }
}

TEST_CASE("city: no two patches overlap and the ground misses the footprints") {
    const Scene s = city_scene(3);
    std::vector<Bounds3> boxes;
    for (const Patch& p : s.patches) boxes.push_back(box_of(p));
    std::size_t coplanar_pairs = 0;
    for (std::size_t i = 0; i < s.patches.size(); ++i)
        for (std::size_t j = i + 1; j < s.patches.size(); ++j) {
            const Patch &a = s.patches[i], &b = s.patches[j];
            const int axis = normal_axis(a.normal);
            if (normal_axis(b.normal) != axis) continue;
            if (std::abs(a.centroid[axis] - b.centroid[axis]) > 1e-9) continue;
            ++coplanar_pairs;
            CHECK(overlap_area(boxes[i], boxes[j], axis) < 1e-12);
        }
    CHECK(coplanar_pairs > 0);
    // The ground covers the square minus the footprints: (3n + 1)² − 4n².
    double ground = 0.0;
    for (const Patch& p : s.patches)
        if (s.surfaces[std::size_t(p.surface)].name.rfind("ground", 0) == 0) ground += p.area;
    CHECK(ground == doctest::Approx(10.0 * 10.0 - 4.0 * 9.0));
    for (const Patch& p : s.patches) {
        if (std::abs(p.centroid.z()) > 1e-12) continue;
        const double fx = std::fmod(p.centroid.x(), 3.0), fy = std::fmod(p.centroid.y(), 3.0);
        CHECK_FALSE((fx > 1.0 && fy > 1.0 && p.centroid.x() < 9.0 && p.centroid.y() < 9.0));
    }
}

TEST_CASE("city: built-in name and its limits") {
    CHECK(is_builtin_scene("city-2"));
    CHECK_FALSE(is_builtin_scene("city-"));
    CHECK_FALSE(is_builtin_scene("city-x"));
    CHECK_FALSE(is_builtin_scene("city-0"));
    const Scene s = load_scene("city-2");
    CHECK(s.patches.size() == 129);
    CHECK(s.camera.has_value());
    CHECK_THROWS_AS(load_scene("city-1001"), OptionError);
    CHECK_THROWS_AS(city_scene(0), OptionError);
    const auto gens = builtin_scene_generators();
    CHECK(std::find(gens.begin(), gens.end(), "city-N") != gens.end());
}
