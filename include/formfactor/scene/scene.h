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
    /// Regions cut out of the surface: coplanar polygons inside it that do not overlap each other
    /// (they may touch each other and the boundary). The surface stands for polygon minus holes:
    /// its patches tile exactly that (subdivide()). VS3: the polygons of its subsurfaces (the
    /// surfaces whose base it is), so that a wall and its window are disjoint, as after View3D's
    /// Separate step.
    std::vector<Polygon> holes;
};

/// Area of a surface: area(polygon) minus the areas of its holes (projected on its plane).
double surface_area(const Surface& s);

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
/// Defaults as in View3D 3.2's source (maxU 12, maxO 8).
struct Vs3Control {
    double eps = 1e-4;
    int maxU = 12, maxO = 8, minO = 0;
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
    std::string name;   ///< file path or built-in name
    std::string title;  ///< VS3 T record or a description
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
    /// The material of surface `s`: its entry of `materials`, or a default Material (grey 0.5,
    /// emissivity 0.9, no emission) when the scene has no such entry.
    const Material& material_of_surface(std::size_t s) const;
    /// The material of patch `i`, through its surface (the default when it has none).
    const Material& material_of(std::size_t i) const;
};

/// Loads a scene: a built-in name (`cornell`, `cornell-empty`, `plates`, `perpendicular`,
/// `cube`, `room-N` / `room-N-obstruction`, the pre-split room of formfactor/scene/room.h, and
/// `city-N`, the open city of formfactor/scene/city.h)
/// or a file path by extension (`.obj`, `.vs3`; meshes `.msh`, `.stl`, `.ply`, `.gltf`, `.glb`,
/// `.off`: formfactor/scene/mesh_io.h). The patches are the surfaces, unsplit;
/// call subdivide() for more. Throws InputError naming file and line on bad input.
Scene load_scene(const std::string& name_or_path);

/// Loads a Wavefront OBJ file (+ its MTL libraries): every face is a surface (CCW = front),
/// faces in a group or object whose name begins with `obstruction` (any case) are
/// obstruction-only; MTL `Kd` is the reflectance, `Ke` the emission, and the non-standard keys
/// `emissivity` and `temperature` (kelvin) set the thermal properties. Surfaces are named
/// `GROUP` (a group of one face) or `GROUP.K` (K-th face of the group, from 1). Patches are the
/// surfaces, unsplit. Throws InputError("FILE", LINE, ...) on bad input.
Scene load_obj(const std::string& path);

/// Loads a View3D 3.2 input file (`.vs3`, formats `F 3` and `F 3a`). Vertex and surface numbers
/// are 1-based in the file, 0-based in the Scene. `S` records are surfaces, `O` records
/// obstruction-only surfaces; the emit column becomes the emissivity of a material per surface
/// (reflectance 1 − ε, grey). `C` is kept in Scene::vs3_control (encl=1 sets
/// Scene::enclosure). Masking (`M`) and null (`N`) surfaces are rejected (not supported).
/// Subsurfaces (base ≠ 0): Surface::base is set and the subsurface's polygon becomes a hole of
/// its base (Surface::holes), so the base's patches cover base minus its subsurfaces (View3D's
/// Separate step, done geometrically: exact for every method). Subsurfaces of subsurfaces
/// nest the same way (each surface loses its direct subsurfaces). Subsurfaces of one base that
/// overlap are an error. A subsurface of an obstruction-only surface cuts no hole (the
/// obstruction has no patches). Combined surfaces (cmb ≠ 0) are kept separate with
/// Surface::combine set: surface_groups() / aggregate_per_surface() merge them as View3D's
/// Combine step does. Throws InputError("FILE", LINE, ...) on bad input.
Scene load_vs3(const std::string& path);

/// A built-in scene by name (see builtin_scene_names()). Throws InputError for an unknown name.
Scene builtin_scene(const std::string& name);

/// Rebuilds scene.patches from the non-obstruction surfaces, in surface order.
/// - n ≥ 1: a convex quad → n×n bilinear children, row-major: row r runs along v0→v3, column c
///   along v0→v1, child index r·n + c, child vertices P(c,r), P(c+1,r), P(c+1,r+1), P(c,r+1).
///   A triangle → n² congruent triangles on the barycentric grid P(i,j) = v0 + i/n (v1−v0) +
///   j/n (v2−v0): row j = 0..n−1, in each row for i = 0..n−1−j the "upright" triangle
///   (P(i,j), P(i+1,j), P(i,j+1)) followed, when i < n−1−j, by the "inverted" one
///   (P(i+1,j), P(i+1,j+1), P(i,j+1)). Any other polygon (and a non-convex quad) is triangulated
///   (triangulate()) and each triangle split as above, triangles in triangulation order.
/// - max_edge L > 0: a convex quad → n_u × n_v with n_u = ⌈max(|v0v1|, |v3v2|)/L⌉,
///   n_v = ⌈max(|v0v3|, |v1v2|)/L⌉ (row-major as above, n_v rows); a triangle → n² with
///   n = ⌈longest edge/L⌉; others triangulated, then each triangle so. Every child edge ≤ L.
/// A surface with holes is first cut into convex pieces that tile polygon minus holes
/// (subtract_holes()), in that order; each piece is then treated as a surface of its own by the
/// rules above and below (so even n = 1 gives several patches for it).
/// A surface without holes stays whole (one patch, whatever its shape) when n = 1 without
/// max_edge, or when all its edges are ≤ L. Children keep the surface's orientation. Throws
/// OptionError("subdivide" / "max_edge") for n < 1, L < 0 or not finite, both set (n > 1 and L
/// > 0), or more than kMaxPatches patches.
void subdivide(Scene& scene, const SubdivisionOptions& options);

/// Throws OptionError("subdivide" / "max_edge") for options subdivide() refuses: n < 1, a
/// negative or non-finite max_edge, or both a max_edge and n > 1.
void validate(const SubdivisionOptions& options);

/// The number of patches subdivide(scene, options) would make, counted without making them (a
/// double: absurd options must not overflow). Throws OptionError like subdivide() for bad
/// options.
double subdivision_patch_count(const Scene& scene, const SubdivisionOptions& options);

/// Upper limit on the number of patches subdivide() makes.
inline constexpr double kMaxPatches = 50e6;

/// Names of the built-in scenes.
std::vector<std::string> builtin_scene_names();
/// The built-in scene generators, as patterns: `room-N`, `room-N-obstruction`
/// (formfactor/scene/room.h) and `city-N` (formfactor/scene/city.h); N in decimal.
std::vector<std::string> builtin_scene_generators();
/// True when `name` is a built-in scene.
bool is_builtin_scene(const std::string& name);

/// Makes a Patch (area, normal, centroid) from a polygon.
Patch make_patch(Polygon polygon, int surface);

/// Validates one polygon as a surface: ≥ 3 vertices, finite coordinates, no zero-length edge,
/// non-zero area (area ≥ 1e-12 · diameter²), planar within kPlanarityTolerance (relative to its
/// diameter), simple. Collinear vertices along an edge are allowed. Throws InputError at
/// `where` with the reason, naming the polygon as `what` ("face", "surface 3", ...).
void validate_polygon(const Polygon& p, const SourceLocation& where,
                      const std::string& what = "polygon");

/// Largest allowed distance of a vertex from the polygon's plane, relative to its diameter.
inline constexpr double kPlanarityTolerance = 1e-6;

}  // namespace formfactor
