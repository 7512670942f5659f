#pragma once
/// Writers for scenes: Wavefront OBJ (+ MTL) and View3D's VS3. Both write to `path + ".tmp"`
/// and rename, so an interrupted run never leaves a half-written file.

#include <string>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// Writes the surfaces (not the patches) as an OBJ file and its materials as `<stem>.mtl`
/// beside it (`mtllib` names it). Each surface is its own group `g NAME`; obstruction-only
/// surfaces whose name does not begin with `obstruction` get the prefix `obstruction_`, so that
/// load_obj() reads them back as obstructions. Materials: `Kd` reflectance, `Ke` emission, and
/// the non-standard keys `emissivity` and `temperature` (kelvin, when set). OBJ has no holes: a
/// surface with holes is written as the convex pieces of polygon minus holes, several faces of
/// its group (read back as surfaces `NAME.1`, `NAME.2`, ...; same area). Coordinates are
/// written with 17 significant digits (exact round trip). Throws Error when a file cannot be
/// written.
void save_obj(const Scene& scene, const std::string& path);

/// Writes the surfaces as a View3D 3.2 file (`F 3`, 1-based numbers, one `V` per distinct
/// vertex). `S` records come first and `O` records after them, as View3D requires (surface
/// numbers, base and cmb refer to that order). Emissivity from each surface's material. The
/// `C` record echoes Scene::vs3_control (or encl from Scene::enclosure). View3D takes triangles
/// and convex quads only: other polygons are triangulated and the pieces written as surfaces
/// combined (cmb) with the first piece (obstructions as several `O` records). Holes are written
/// as the subsurfaces they come from (Surface::base). Throws GeometryError when such a polygon
/// is the base of a subsurface or when a surface has holes that are not its subsurfaces, Error
/// when the file cannot be written.
void save_vs3(const Scene& scene, const std::string& path);

}  // namespace formfactor
