// The city benchmark scene (see formfactor/scene/city.h).

#include "formfactor/scene/city.h"

#include <string>

#include "formfactor/core/error.h"

namespace formfactor {

namespace {

// The rectangle o + [0, a] u + [0, b] v (u, v unit axis vectors, front normal u × v, a and b
// whole numbers) as a × b unit squares, each its own surface named `prefix.K`, in the order
// subdivide() would split it: rows along v, columns along u.
void add_rect(Scene& s, const char* prefix, int material, const Vec3& o, const Vec3& u, int a,
              const Vec3& v, int b) {
    for (int r = 0; r < b; ++r)
        for (int c = 0; c < a; ++c) {
            Surface f;
            f.name = std::string(prefix) + "." + std::to_string(s.surfaces.size() + 1);
            f.material = material;
            const Vec3 p = o + c * u + r * v;
            f.polygon.vertices = {p, p + u, p + u + v, p + v};
            f.where = {s.name, 0};
            s.surfaces.push_back(std::move(f));
        }
}

}  // namespace

int city_building_height(int x, int y) { return 1 + (x + 2 * y) % 4; }

std::size_t city_patch_count(int n) {
    const auto m = static_cast<std::size_t>(n);
    std::size_t walls = 0;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            walls += 8 * static_cast<std::size_t>(city_building_height(x, y));
    return (m + 1) * (5 * m + 1) + 4 * m * m + walls;
}

Scene city_scene(int n) {
    if (n < 1 || n > kMaxCitySize)
        throw OptionError("city", "n must be from 1 to " + std::to_string(kMaxCitySize));
    Scene s;
    s.name = "city-" + std::to_string(n);
    s.title = "City of " + std::to_string(n) + "x" + std::to_string(n) +
              " buildings (2x2, 1 to 4 storeys, streets 1 wide) on a ground plane, open to the sky";
    Material ground, wall, roof;
    ground.name = "asphalt";
    ground.reflectance = Rgb::Constant(0.1);
    ground.emissivity = 0.95;
    wall.name = "concrete";
    wall.reflectance = Rgb::Constant(0.35);
    wall.emissivity = 0.9;
    roof.name = "roof";
    roof.reflectance = Rgb::Constant(0.2);
    roof.emissivity = 0.9;
    s.materials = {ground, wall, roof};
    const Vec3 X = Vec3::UnitX(), Y = Vec3::UnitY(), Z = Vec3::UnitZ();
    const int side = 3 * n + 1;
    s.surfaces.reserve(city_patch_count(n));
    // Ground: the streets along x, then the pieces between the buildings of each row.
    for (int y = 0; y <= n; ++y) add_rect(s, "ground", 0, Vec3(0, 3.0 * y, 0), X, side, Y, 1);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x <= n; ++x)
            add_rect(s, "ground", 0, Vec3(3.0 * x, 3.0 * y + 1, 0), X, 1, Y, 2);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const double x0 = 3.0 * x + 1, y0 = 3.0 * y + 1;
            const int h = city_building_height(x, y);
            add_rect(s, "wall", 1, Vec3(x0, y0, 0), Z, h, Y, 2);      // −x
            add_rect(s, "wall", 1, Vec3(x0 + 2, y0, 0), Y, 2, Z, h);  // +x
            add_rect(s, "wall", 1, Vec3(x0, y0, 0), X, 2, Z, h);      // −y
            add_rect(s, "wall", 1, Vec3(x0, y0 + 2, 0), Z, h, X, 2);  // +y
            add_rect(s, "roof", 2, Vec3(x0, y0, h), X, 2, Y, 2);      // +z
        }
    s.enclosure = false;
    Camera cam;
    cam.eye = Vec3(-0.35 * side, -0.55 * side, 0.75 * side);
    cam.target = Vec3(0.5 * side, 0.5 * side, 0);
    cam.up = Z;
    cam.fov_degrees = 45.0;
    s.camera = cam;
    subdivide(s, SubdivisionOptions{});
    return s;
}

}  // namespace formfactor
