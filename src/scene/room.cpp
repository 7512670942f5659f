// The room benchmark scene (see formfactor/scene/room.h).

#include "formfactor/scene/room.h"

#include <string>

#include "formfactor/core/error.h"

namespace formfactor {

namespace {

// Splits the parallelogram o + [0,1] e1 + [0,1] e2 (front normal e1 × e2) into m×m surfaces.
void add_face(Scene& s, const Vec3& o, const Vec3& e1, const Vec3& e2, int m,
              const std::string& prefix, bool obstruction) {
    for (int j = 0; j < m; ++j)
        for (int i = 0; i < m; ++i) {
            auto at = [&](int a, int b) { return Vec3(o + (a * e1 + b * e2) / m); };
            Surface f;
            f.name = prefix + "." + std::to_string(s.surfaces.size() + 1);
            f.polygon.vertices = {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
            f.obstruction = obstruction;
            f.where = {s.name, 0};
            s.surfaces.push_back(std::move(f));
        }
}

}  // namespace

Scene room_scene(int n, RoomBox box) {
    if (n < 1 || (box == RoomBox::kPatches && (n < 2 || n % 2 != 0)) || n > 4096)
        throw OptionError("room", "n must be ≥ 2 and even (≥ 1 without box patches), ≤ 4096");
    Scene s;
    s.name = "room-" + std::to_string(n);
    s.title = "Unit cube room (faces inward, " + std::to_string(n) + "x" + std::to_string(n) +
              ") with a floating box [0.3,0.7]x[0.3,0.7]x[0.1,0.5]";
    s.materials.push_back(Material{});
    using V = Vec3;
    add_face(s, V(0, 0, 0), V(0, 1, 0), V(0, 0, 1), n, "wall", false);
    add_face(s, V(1, 0, 0), V(0, 0, 1), V(0, 1, 0), n, "wall", false);
    add_face(s, V(0, 0, 0), V(0, 0, 1), V(1, 0, 0), n, "wall", false);
    add_face(s, V(0, 1, 0), V(1, 0, 0), V(0, 0, 1), n, "wall", false);
    add_face(s, V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), n, "wall", false);
    add_face(s, V(0, 0, 1), V(0, 1, 0), V(1, 0, 0), n, "wall", false);
    if (box != RoomBox::kNone) {
        const bool ob = box == RoomBox::kObstruction;
        const int m = ob ? 1 : n / 2;
        const V lo(0.3, 0.3, 0.1);
        const double e = 0.4;
        add_face(s, lo, V(0, 0, e), V(0, e, 0), m, "box", ob);
        add_face(s, lo + V(e, 0, 0), V(0, e, 0), V(0, 0, e), m, "box", ob);
        add_face(s, lo, V(e, 0, 0), V(0, 0, e), m, "box", ob);
        add_face(s, lo + V(0, e, 0), V(0, 0, e), V(e, 0, 0), m, "box", ob);
        add_face(s, lo, V(0, e, 0), V(e, 0, 0), m, "box", ob);
        add_face(s, lo + V(0, 0, e), V(e, 0, 0), V(0, e, 0), m, "box", ob);
    }
    s.enclosure = true;
    subdivide(s, SubdivisionOptions{});
    return s;
}

}  // namespace formfactor
