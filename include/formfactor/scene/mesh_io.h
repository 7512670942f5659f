#pragma once
/// Readers of mesh files: Gmsh's `.msh` (our own reader) and, through Open Asset Import, STL,
/// PLY, glTF 2.0 and OFF. load_scene() picks them by extension.

#include <string>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// Loads a Gmsh mesh (`.msh`, versions 2.2 and 4.1, ASCII or binary; our own reader of the
/// documented format). Every triangle and quad (element types 2, 3) is a surface whose front
/// follows the node order (counter-clockwise seen from the front); points and lines are
/// ignored, volume elements ignored with a warning, curved (second-order) surface elements
/// refused. The elements of one 2-D physical group form one group of surfaces: each is named
/// after the group ($PhysicalNames; `physical-TAG` when unnamed) and combined (Surface::combine)
/// with the group's first element, so that surface_groups() gives one row per physical group,
/// as for a VS3 file. Elements outside any physical group are grouped by their geometric
/// entity (`surface-TAG`). A group whose name begins with `obstruction` (any case) is
/// obstruction-only. A closed surface (every edge shared by exactly two elements; checked for
/// the whole mesh and for each group) whose elements do not all face the same side is an
/// error naming an element of the smaller side; so is an element with the nodes of another
/// (an element in two physical groups). Throws InputError("FILE", LINE, ...) on bad input (the
/// line of a text file; in a binary file line 0 and the byte offset or element in the
/// message).
Scene load_msh(const std::string& path);

/// Loads STL (ASCII or binary), PLY, glTF 2.0 (`.gltf`, `.glb`) or OFF through Open Asset
/// Import. Every face of three or more vertices is a surface (front: counter-clockwise vertex
/// order; PLY and OFF polygons stay polygons); points and lines are skipped. Each mesh of each
/// node is one group of surfaces combined (Surface::combine) with its first face, named as the
/// file names it: the node, else the mesh (the ASCII STL's `solid NAME`), else the file's stem;
/// `NAME.K` for the K-th mesh of a node with several, and a repeated name gets `.2`, `.3`, ...
/// A group whose name begins with `obstruction` (any case) is obstruction-only. Node
/// transformations are applied (in double precision; coordinates come from assimp as float).
/// glTF: the base colour (factor) is the reflectance, the emissive factor (times its strength)
/// the emission, one Material per glTF material; other formats use the default material.
/// Throws InputError(path, 0, ...) naming the mesh and face (1-based) for a face that
/// validate_polygon() refuses or that indexes a missing vertex, and for anything assimp
/// reports as an error (including what it would repair by a guess).
Scene load_mesh(const std::string& path);

}  // namespace formfactor
