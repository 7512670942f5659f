#pragma once
/// The scene model: surfaces (what the file drew), their materials, obstruction-only surfaces,
/// and the patches that subdivision makes of them (DESIGN.md, "Definitions and conventions").

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor {

/// Where something came from, for error messages: "file:line".
struct SourceLocation {
    std::string file;
    int line = 0;
};

/// Surface properties for both audiences. Graphics: RGB reflectance ρ and emission E (the
/// radiosity equation B = E + ρFB). Thermal: grey emissivity ε and temperature T in kelvin
/// (NaN when not given).
struct Material {
    std::string name = "default";
    Rgb reflectance = Rgb::Constant(0.5);
    Rgb emission = Rgb::Zero();
    double emissivity = 0.9;
    double temperature = std::numeric_limits<double>::quiet_NaN();
};

/// A surface as drawn in the input. Obstruction-only surfaces block but have no row or column.
struct Surface {
    std::string name;
    Polygon polygon;
    int material = 0;          ///< index into Scene::materials
    bool obstruction = false;  ///< obstruction-only (OBJ `obstruction*` group, VS3 `O` record)
    int base = -1;             ///< VS3: index of the base surface of a subsurface, else -1
    int combine = -1;          ///< VS3 cmb: index of the surface this one is combined with, else -1
    SourceLocation where;      ///< the file and line that defined it
};

/// A patch: a row and a column of the form-factor matrix.
struct Patch {
    Polygon polygon;
    int surface = -1;  ///< index into Scene::surfaces
    double area = 0.0;
    Vec3 normal = Vec3::Zero();
    Vec3 centroid = Vec3::Zero();
};

/// A pinhole camera (for rendering); built-in scenes carry theirs.
struct Camera {
    Vec3 eye = Vec3(0, 0, 1);
    Vec3 target = Vec3::Zero();
    Vec3 up = Vec3::UnitY();
    double fov_degrees = 40.0;  ///< vertical field of view
};

/// View3D's control record (`C`), kept so that outputs can echo it.
struct Vs3Control {
    double eps = 1e-4;
    int maxU = 8, maxO = 8, minO = 0;
    int encl = 0, emit = 0, row = 0, col = 0, out = 0, list = 0;
};

/// Options of subdivision: at most one of n and max_edge is active.
struct SubdivisionOptions {
    int n = 1;              ///< --subdivide N: quads into N×N, triangles into N², others sensibly
    double max_edge = 0.0;  ///< --max-edge L (> 0): split until every patch edge ≤ L
};

/// A validated scene. Patch order: surfaces in file order (obstructions skipped), the children
/// of a surface consecutive, row-major.
struct Scene {
    std::string name;    ///< file path or built-in name
    std::string title;   ///< VS3 T record or a description
    std::vector<Material> materials;
    std::vector<Surface> surfaces;
    std::vector<Patch> patches;
    std::vector<std::string> warnings;  ///< things the user should know (ignored options, ...)
    std::optional<Camera> camera;
    std::optional<Vs3Control> vs3_control;
    /// True when the scene is known to be a closed enclosure (built-in `cube`, VS3 encl=1).
    bool enclosure = false;

    /// Surfaces that are obstruction-only.
    std::size_t obstruction_count() const;
    /// Total area of the patches.
    double total_patch_area() const;
    /// Bounds of every surface (patches and obstructions).
    Bounds3 bounds() const;
};

/// Loads a scene: a built-in name (`cornell`, `cornell-empty`, `plates`, `perpendicular`,
/// `cube`) or a file path by extension (`.obj`, `.vs3`). The patches are the surfaces, unsplit;
/// call subdivide() for more. Throws InputError naming file and line on bad input.
Scene load_scene(const std::string& name_or_path);

/// Rebuilds scene.patches from the non-obstruction surfaces. Throws OptionError on a bad value.
void subdivide(Scene& scene, const SubdivisionOptions& options);

/// Names of the built-in scenes.
std::vector<std::string> builtin_scene_names();
/// True when `name` is a built-in scene.
bool is_builtin_scene(const std::string& name);

/// Makes a Patch (area, normal, centroid) from a polygon.
Patch make_patch(Polygon polygon, int surface);

/// Validates one polygon as a surface: ≥ 3 vertices, finite coordinates, non-zero area, no
/// degenerate edges, planar within kPlanarityTolerance (relative to its diameter), simple.
/// Throws InputError at `where` with the reason.
void validate_polygon(const Polygon& p, const SourceLocation& where);

/// Largest allowed distance of a vertex from the polygon's plane, relative to its diameter.
inline constexpr double kPlanarityTolerance = 1e-6;

}  // namespace formfactor
