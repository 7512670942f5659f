#include "formfactor/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/energyplus.h"
#include "formfactor/scene/mesh_io.h"
#include "scene/text.h"

namespace formfactor {

std::size_t Scene::obstruction_count() const {
    return static_cast<std::size_t>(std::count_if(surfaces.begin(), surfaces.end(),
                                                  [](const Surface& s) { return s.obstruction; }));
}

double Scene::total_patch_area() const {
    double a = 0.0;
    for (const Patch& p : patches) a += p.area;
    return a;
}

const Material& Scene::material_of_surface(std::size_t s) const {
    static const Material kDefault;
    if (s >= surfaces.size()) return kDefault;
    const int m = surfaces[s].material;
    return m >= 0 && static_cast<std::size_t>(m) < materials.size()
               ? materials[static_cast<std::size_t>(m)]
               : kDefault;
}

const Material& Scene::material_of(std::size_t i) const {
    static const Material kDefault;
    if (i >= patches.size() || patches[i].surface < 0) return kDefault;
    return material_of_surface(static_cast<std::size_t>(patches[i].surface));
}

Bounds3 Scene::bounds() const {
    Bounds3 b;
    for (const Surface& s : surfaces)
        for (const Vec3& v : s.polygon.vertices) b.extend(v);
    return b;
}

double surface_area(const Surface& s) {
    const Vec3 n = normal(s.polygon);
    double a = area(s.polygon);
    for (const Polygon& h : s.holes) a -= std::abs(area_vector(h).dot(n));
    return a;
}

Patch make_patch(Polygon polygon, int surface) {
    Patch p;
    p.area = area(polygon);
    p.normal = normal(polygon);
    p.centroid = centroid(polygon);
    p.polygon = std::move(polygon);
    p.surface = surface;
    return p;
}

void validate_polygon(const Polygon& p, const SourceLocation& where, const std::string& what) {
    auto fail = [&](const std::string& msg) { throw InputError(where.file, where.line, msg); };
    const std::size_t n = p.size();
    if (n < 3) fail(what + " has " + std::to_string(n) + " vertices (at least 3 needed)");
    for (std::size_t k = 0; k < n; ++k)
        if (!p[k].allFinite())
            fail(what + " has a coordinate that is not finite (vertex " + std::to_string(k + 1) +
                 ": " + detail::exact(p[k].x()) + " " + detail::exact(p[k].y()) + " " +
                 detail::exact(p[k].z()) + ")");
    const double d = diameter(p);
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t m = (k + 1) % n;
        if ((p[m] - p[k]).norm() <= 1e-12 * d)
            fail(what + " has a zero-length edge (vertices " + std::to_string(k + 1) + " and " +
                 std::to_string(m + 1) + " coincide)");
    }
    const double a = area(p);
    if (!(a >= 1e-12 * d * d)) {
        // Zero net area but not all on one line: the polygon folds over itself (a bow tie).
        double spread = 0.0;
        for (std::size_t j = 1; j < n; ++j)
            for (std::size_t k = j + 1; k < n; ++k)
                spread = std::max(spread, (p[j] - p[0]).cross(p[k] - p[0]).norm());
        if (spread > 1e-9 * d * d) fail(what + " is not simple (its edges cross or touch)");
    }
    if (!(a >= 1e-12 * d * d))
        fail(what + " is degenerate (zero area: area " +
             detail::short_number(d > 0 ? a / (d * d) : 0) + " of its size squared)");
    const double defect = planarity_defect(p);
    if (!(defect <= kPlanarityTolerance))
        fail(what + " is not planar (defect " + detail::short_number(defect) +
             " of its size, tolerance " + detail::short_number(kPlanarityTolerance) + ")");
    if (!is_simple(p)) fail(what + " is not simple (its edges cross or touch)");
}

Scene load_scene(const std::string& name_or_path) {
    if (is_builtin_scene(name_or_path)) return builtin_scene(name_or_path);
    std::string ext = std::filesystem::path(name_or_path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".obj") return load_obj(name_or_path);
    if (ext == ".vs3") return load_vs3(name_or_path);
    if (ext == ".idf" || ext == ".epjson") return load_energyplus(name_or_path);
    if (ext == ".msh") return load_msh(name_or_path);
    if (ext == ".stl" || ext == ".ply" || ext == ".gltf" || ext == ".glb" || ext == ".off")
        return load_mesh(name_or_path);
    std::string names;
    for (const std::string& b : builtin_scene_names()) names += (names.empty() ? "" : ", ") + b;
    std::string generators;
    for (const std::string& g : builtin_scene_generators())
        generators += (generators.empty() ? "" : ", ") + g;
    if (ext.empty())
        throw InputError(
            name_or_path, 0,
            "not a built-in scene (" + names + ") nor a generated one (" + generators +
                ") and no file extension (.obj, .vs3, .idf, .epJSON, .msh, .stl, .ply, .gltf, "
                ".glb or .off expected)");
    throw InputError(
        name_or_path, 0,
        "unknown file extension '" + ext +
            "' (.obj, .vs3, .idf, .epJSON, .msh, .stl, .ply, .gltf, .glb or .off expected, or a "
            "built-in scene: " +
            names + ")");
}

}  // namespace formfactor
