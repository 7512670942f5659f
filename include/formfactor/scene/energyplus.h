#pragma once
/// EnergyPlus building models as scenes: one zone (a closed enclosure) at a time.
///
/// Read from `.idf` (IDF's object/field text: objects end with `;`, fields are separated by
/// `,`, `!` starts a comment; class names are case-insensitive) or `.epJSON` (JSON, objects keyed
/// by class, then by name). Read: `Version`, `Building` (North Axis), `Zone` (name, Direction of
/// Relative North, X/Y/Z Origin), `GlobalGeometryRules` (Starting Vertex Position, Vertex Entry
/// Direction, Coordinate System), the surfaces `BuildingSurface:Detailed`, `Wall:Detailed`,
/// `RoofCeiling:Detailed`, `Floor:Detailed` (with or without the Space Name field of
/// EnergyPlus ≥ 9.6), and `FenestrationSurface:Detailed` (windows, doors, glass doors), which are
/// cut out of their base surface as holes (Surface::holes, Surface::base); the simplified
/// (rectangular) objects `Wall:Exterior`, `Wall:Adiabatic`, `Wall:Underground`, `Wall:Interzone`,
/// `Roof`, `Ceiling:Adiabatic`, `Ceiling:Interzone`, `Floor:GroundContact`, `Floor:Adiabatic`,
/// `Floor:Interzone` and, on them, `Window`, `Door`, `GlazedDoor` and their `:Interzone`
/// forms, whose vertices are made as EnergyPlus makes them (SurfaceGeometry's rectangles: the
/// lower left corner, azimuth and tilt; subsurfaces from their base's corner). Every other
/// object is skipped.
///
/// Conventions, as EnergyPlus states them: vertices run counter-clockwise seen from outside the
/// zone (or clockwise with `Vertex Entry Direction = Clockwise`), so the reader reverses them to
/// face into the zone (formfactor's front); the starting corner only rotates the vertex list and
/// changes nothing. With `Coordinate System = Relative` (the default) a zone's vertices are
/// rotated by the zone's Direction of Relative North and moved by its origin, then rotated by
/// the building's North Axis; with `World`/`Absolute` they are used as given. A simplified
/// surface's azimuth follows `Coordinate System`, its starting corner `Rectangular Surface
/// Coordinate System` (relative: moved into the zone like a vertex). Rigid motions leave
/// F unchanged; they matter for the geometry written out (VTU, OBJ).

#include <string>
#include <vector>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// The zone names of an EnergyPlus model, in file order. Throws InputError("FILE", LINE, ...) on
/// bad input.
std::vector<std::string> energyplus_zones(const std::string& path);

/// One zone of an EnergyPlus model (`.idf` or `.epJSON`, by extension) as a closed enclosure:
/// its surfaces, named as in the model, in file order, windows
/// and doors as holes of their base surfaces, each base surface followed by its windows and doors
/// (epJSON lists objects by class: a model that mixes classes orders them by class there);
/// Scene::title is the zone's name (as written in the
/// model), Scene::enclosure is true. `zone` is matched case-insensitively, as EnergyPlus
/// matches names; empty: the model's only zone. Throws InputError naming the file and line (IDF)
/// or the object (epJSON) on bad input, for an unknown zone, and when `zone` is empty and the
/// model has several zones (the message lists them).
Scene load_energyplus(const std::string& path, const std::string& zone = "");

/// The same from text in memory; `path` names it in messages and its extension chooses the
/// syntax (`.epjson` = JSON, anything else IDF). For tests and fuzzing.
Scene load_energyplus_text(const std::string& text, const std::string& path,
                           const std::string& zone = "");

}  // namespace formfactor
