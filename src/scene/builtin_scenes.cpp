// Built-in scenes: the Cornell box (with and without its blocks) and three closed-form test
// configurations. Each is validated like a file.

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/text.h"
#include "formfactor/core/error.h"
#include "formfactor/scene/city.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

namespace {

struct Builder {
    Scene scene;

    int material(const std::string& name, const Rgb& rho, const Rgb& e = Rgb::Zero()) {
        Material m;
        m.name = name;
        m.reflectance = rho;
        m.emission = e;
        scene.materials.push_back(m);
        return static_cast<int>(scene.materials.size()) - 1;
    }
    void surface(const std::string& name, std::vector<Vec3> v, int material,
                 bool obstruction = false) {
        Surface s;
        s.name = name;
        s.polygon.vertices = std::move(v);
        s.material = material;
        s.obstruction = obstruction;
        s.where = {scene.name, 0};
        validate_polygon(s.polygon, s.where, "built-in surface '" + name + "'");
        scene.surfaces.push_back(std::move(s));
    }
    Scene finish() {
        subdivide(scene, SubdivisionOptions{});
        return std::move(scene);
    }
};

// The Cornell box as published by the Cornell Program of Computer Graphics ("Cornell Box Data",
// http://www.graphics.cornell.edu/online/box/data.html): millimetres, camera at
// (278, 273, −800) looking along +z, up +y, focal length 35 mm on a 25 mm × 25 mm film
// (vertical fov 2·atan(12.5/35) = 39.3077°). The published vertex order already runs
// counter-clockwise seen from inside the box (walls) and from outside the blocks.
//
// Departures from the published list, all to keep every surface planar and nothing overlapping:
// - The red (left) wall's four published corners are 3.2 mm out of plane (defect ~4e-3 of its
//   size): it is split along its diagonal into two triangles ("left.1", "left.2").
// - The ceiling is split around the light's hole x ∈ [213, 343], z ∈ [227, 332] into four
//   quads (front, back, left and right of the light).
// - The light (130 × 105 mm) is its own surface, facing down, in the ceiling plane y = 548.8:
//   it fills the hole exactly, so nothing overlaps and nothing leaks.
// Colours are the RGB reductions of the published spectra in common use (Bitterli's "Rendering
// resources" Cornell box): white (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05), green (0.14,
// 0.45, 0.091); the light's emitted radiance (17, 12, 4).
Scene cornell(bool with_blocks) {
    Builder b;
    b.scene.name = with_blocks ? "cornell" : "cornell-empty";
    b.scene.title = with_blocks ? "Cornell box (published geometry, with the two blocks)"
                                : "Cornell box (published geometry, without the blocks)";
    const int white = b.material("white", Rgb(0.725, 0.71, 0.68));
    const int red = b.material("red", Rgb(0.63, 0.065, 0.05));
    const int green = b.material("green", Rgb(0.14, 0.45, 0.091));
    const int light = b.material("light", Rgb(0.78, 0.78, 0.78), Rgb(17, 12, 4));
    using V = Vec3;
    b.surface("floor", {V(552.8, 0, 0), V(0, 0, 0), V(0, 0, 559.2), V(549.6, 0, 559.2)}, white);
    const double y = 548.8;
    // Ceiling (published: 556 548.8 0 / 556 548.8 559.2 / 0 548.8 559.2 / 0 548.8 0), facing
    // down, split around the light.
    b.surface("ceiling.front", {V(556, y, 0), V(556, y, 227), V(0, y, 227), V(0, y, 0)}, white);
    b.surface("ceiling.back", {V(556, y, 332), V(556, y, 559.2), V(0, y, 559.2), V(0, y, 332)},
              white);
    b.surface("ceiling.left", {V(556, y, 227), V(556, y, 332), V(343, y, 332), V(343, y, 227)},
              white);
    b.surface("ceiling.right", {V(213, y, 227), V(213, y, 332), V(0, y, 332), V(0, y, 227)}, white);
    b.surface("light", {V(343, y, 227), V(343, y, 332), V(213, y, 332), V(213, y, 227)}, light);
    b.surface("back",
              {V(549.6, 0, 559.2), V(0, 0, 559.2), V(0, 548.8, 559.2), V(556, 548.8, 559.2)},
              white);
    b.surface("right", {V(0, 0, 559.2), V(0, 0, 0), V(0, 548.8, 0), V(0, 548.8, 559.2)}, green);
    // Published left wall: 552.8 0 0 / 549.6 0 559.2 / 556 548.8 559.2 / 556 548.8 0.
    b.surface("left.1", {V(552.8, 0, 0), V(549.6, 0, 559.2), V(556, 548.8, 559.2)}, red);
    b.surface("left.2", {V(552.8, 0, 0), V(556, 548.8, 559.2), V(556, 548.8, 0)}, red);
    if (with_blocks) {
        b.surface("short.top",
                  {V(130, 165, 65), V(82, 165, 225), V(240, 165, 272), V(290, 165, 114)}, white);
        b.surface("short.1", {V(290, 0, 114), V(290, 165, 114), V(240, 165, 272), V(240, 0, 272)},
                  white);
        b.surface("short.2", {V(130, 0, 65), V(130, 165, 65), V(290, 165, 114), V(290, 0, 114)},
                  white);
        b.surface("short.3", {V(82, 0, 225), V(82, 165, 225), V(130, 165, 65), V(130, 0, 65)},
                  white);
        b.surface("short.4", {V(240, 0, 272), V(240, 165, 272), V(82, 165, 225), V(82, 0, 225)},
                  white);
        b.surface("tall.top",
                  {V(423, 330, 247), V(265, 330, 296), V(314, 330, 456), V(472, 330, 406)}, white);
        b.surface("tall.1", {V(423, 0, 247), V(423, 330, 247), V(472, 330, 406), V(472, 0, 406)},
                  white);
        b.surface("tall.2", {V(472, 0, 406), V(472, 330, 406), V(314, 330, 456), V(314, 0, 456)},
                  white);
        b.surface("tall.3", {V(314, 0, 456), V(314, 330, 456), V(265, 330, 296), V(265, 0, 296)},
                  white);
        b.surface("tall.4", {V(265, 0, 296), V(265, 330, 296), V(423, 330, 247), V(423, 0, 247)},
                  white);
    }
    Camera cam;
    cam.eye = V(278, 273, -800);
    cam.target = V(278, 273, -799);
    cam.up = V(0, 1, 0);
    cam.fov_degrees = 2.0 * std::atan(12.5 / 35.0) * 180.0 / kPi;  // 39.3077°
    b.scene.camera = cam;
    return b.finish();
}

Scene plates() {
    Builder b;
    b.scene.name = "plates";
    b.scene.title = "Two parallel unit squares 1 apart, facing each other";
    const int m = b.material("grey", Rgb::Constant(0.5));
    using V = Vec3;
    b.surface("bottom", {V(0, 0, 0), V(1, 0, 0), V(1, 1, 0), V(0, 1, 0)}, m);  // faces +z
    b.surface("top", {V(0, 0, 1), V(0, 1, 1), V(1, 1, 1), V(1, 0, 1)}, m);     // faces −z
    return b.finish();
}

Scene perpendicular() {
    Builder b;
    b.scene.name = "perpendicular";
    b.scene.title = "Two unit squares sharing an edge at 90 degrees (floor and wall)";
    const int m = b.material("grey", Rgb::Constant(0.5));
    using V = Vec3;
    // Floor z = 0 facing +z; wall y = 0 facing +y; common edge along x from (0,0,0) to (1,0,0).
    b.surface("floor", {V(0, 0, 0), V(1, 0, 0), V(1, 1, 0), V(0, 1, 0)}, m);
    b.surface("wall", {V(0, 0, 0), V(0, 0, 1), V(1, 0, 1), V(1, 0, 0)}, m);
    return b.finish();
}

Scene cube() {
    Builder b;
    b.scene.name = "cube";
    b.scene.title = "The closed unit cube, faces inward";
    b.scene.enclosure = true;
    const int m = b.material("grey", Rgb::Constant(0.5));
    using V = Vec3;
    // Order: x=0, x=1, y=0, y=1, z=0, z=1; each faces the inside.
    b.surface("x0", {V(0, 0, 0), V(0, 1, 0), V(0, 1, 1), V(0, 0, 1)}, m);  // +x
    b.surface("x1", {V(1, 0, 0), V(1, 0, 1), V(1, 1, 1), V(1, 1, 0)}, m);  // −x
    b.surface("y0", {V(0, 0, 0), V(0, 0, 1), V(1, 0, 1), V(1, 0, 0)}, m);  // +y
    b.surface("y1", {V(0, 1, 0), V(1, 1, 0), V(1, 1, 1), V(0, 1, 1)}, m);  // −y
    b.surface("z0", {V(0, 0, 0), V(1, 0, 0), V(1, 1, 0), V(0, 1, 0)}, m);  // +z
    b.surface("z1", {V(0, 0, 1), V(0, 1, 1), V(1, 1, 1), V(1, 0, 1)}, m);  // −z
    return b.finish();
}

}  // namespace

std::vector<std::string> builtin_scene_names() {
    return {"cornell", "cornell-empty", "plates", "perpendicular", "cube"};
}

std::vector<std::string> builtin_scene_generators() {
    return {"room-N", "room-N-obstruction", "city-N"};
}

namespace {

// "room-N" or "room-N-obstruction" (formfactor/scene/room.h): N, and whether the box is an
// obstruction; N = 0 when the name is not of that form.
int parse_room_name(const std::string& name, bool& obstruction) {
    obstruction = false;
    if (name.rfind("room-", 0) != 0) return 0;
    std::string rest = name.substr(5);
    const std::string suffix = "-obstruction";
    if (rest.size() > suffix.size() &&
        rest.compare(rest.size() - suffix.size(), suffix.size(), suffix) == 0) {
        obstruction = true;
        rest.resize(rest.size() - suffix.size());
    }
    std::size_t n = 0;
    if (rest.size() > 4 || !detail::parse_size(rest, n)) return 0;
    return static_cast<int>(n);
}

// "city-N" (formfactor/scene/city.h): N, or 0 when the name is not of that form.
int parse_city_name(const std::string& name) {
    if (name.rfind("city-", 0) != 0) return 0;
    const std::string rest = name.substr(5);
    if (rest.empty() || rest.size() > 4 ||
        !std::all_of(rest.begin(), rest.end(), [](char c) { return c >= '0' && c <= '9'; }))
        return 0;
    return std::stoi(rest);
}

// The fixed names and the generators, for messages.
std::string known_scenes() {
    std::string names;
    for (const std::string& b : builtin_scene_names()) names += (names.empty() ? "" : ", ") + b;
    for (const std::string& g : builtin_scene_generators()) names += ", " + g;
    return names;
}

}  // namespace

bool is_builtin_scene(const std::string& name) {
    const auto names = builtin_scene_names();
    bool ob = false;
    return std::find(names.begin(), names.end(), name) != names.end() ||
           parse_room_name(name, ob) > 0 || parse_city_name(name) > 0;
}

Scene builtin_scene(const std::string& name) {
    bool room_obstruction = false;
    if (const int n = parse_room_name(name, room_obstruction); n > 0)
        return room_scene(n, room_obstruction ? RoomBox::kObstruction : RoomBox::kPatches);
    if (const int n = parse_city_name(name); n > 0) return city_scene(n);
    if (name == "cornell") return cornell(true);
    if (name == "cornell-empty") return cornell(false);
    if (name == "plates") return plates();
    if (name == "perpendicular") return perpendicular();
    if (name == "cube") return cube();
    throw InputError(name, 0, "unknown built-in scene (known: " + known_scenes() + ")");
}

}  // namespace formfactor
