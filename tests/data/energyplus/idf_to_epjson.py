#!/usr/bin/env python3
"""Converts the geometry objects of an EnergyPlus IDF file to epJSON (EnergyPlus's schema
names): how the .epJSON files of this folder were made from their .idf files, independently of
formfactor's readers. Usage: idf_to_epjson.py IN.idf OUT.epJSON"""

import json
import re
import sys

FIELDS = {
    "Version": ["version_identifier"],
    "Building": ["north_axis", "terrain", "loads_convergence_tolerance_value",
                 "temperature_convergence_tolerance_value", "solar_distribution",
                 "maximum_number_of_warmup_days", "minimum_number_of_warmup_days"],
    "GlobalGeometryRules": ["starting_vertex_position", "vertex_entry_direction",
                            "coordinate_system", "daylighting_reference_point_coordinate_system",
                            "rectangular_surface_coordinate_system"],
    "Zone": ["direction_of_relative_north", "x_origin", "y_origin", "z_origin", "type",
             "multiplier", "ceiling_height", "volume", "floor_area",
             "zone_inside_convection_algorithm", "zone_outside_convection_algorithm",
             "part_of_total_floor_area"],
    "BuildingSurface:Detailed": ["surface_type", "construction_name", "zone_name",
                                 "outside_boundary_condition",
                                 "outside_boundary_condition_object", "sun_exposure",
                                 "wind_exposure", "view_factor_to_ground", "number_of_vertices"],
    "FenestrationSurface:Detailed": ["surface_type", "construction_name", "building_surface_name",
                                     "outside_boundary_condition_object", "view_factor_to_ground",
                                     "frame_and_divider_name", "multiplier", "number_of_vertices"],
    "Shading:Zone:Detailed": ["base_surface_name", "transmittance_schedule_name",
                              "number_of_vertices"],
}
# The simplified (rectangular) objects, as of EnergyPlus 9.0 (no Space Name).
_RECT = ["azimuth_angle", "tilt_angle", "starting_x_coordinate", "starting_y_coordinate",
         "starting_z_coordinate", "length"]
for _cls, _obc, _side in [("Wall:Exterior", False, "height"), ("Wall:Adiabatic", False, "height"),
                          ("Wall:Underground", False, "height"),
                          ("Wall:Interzone", True, "height"), ("Roof", False, "width"),
                          ("Ceiling:Adiabatic", False, "width"),
                          ("Ceiling:Interzone", True, "width"),
                          ("Floor:GroundContact", False, "width"),
                          ("Floor:Adiabatic", False, "width"), ("Floor:Interzone", True, "width")]:
    FIELDS[_cls] = (["construction_name", "zone_name"] +
                    (["outside_boundary_condition_object"] if _obc else []) + _RECT + [_side])
_SUB = ["multiplier", "starting_x_coordinate", "starting_z_coordinate", "length", "height"]
for _cls in ["Window", "GlazedDoor"]:
    FIELDS[_cls] = ["construction_name", "building_surface_name", "frame_and_divider_name"] + _SUB
FIELDS["Door"] = ["construction_name", "building_surface_name"] + _SUB
for _cls in ["Window:Interzone", "Door:Interzone", "GlazedDoor:Interzone"]:
    FIELDS[_cls] = (["construction_name", "building_surface_name",
                     "outside_boundary_condition_object"] + _SUB)
UNNAMED = {"Version", "GlobalGeometryRules"}   # objects without a Name field
WITH_VERTICES = {"BuildingSurface:Detailed", "FenestrationSurface:Detailed",
                 "Shading:Zone:Detailed"}


def value(text):
    try:
        return int(text) if re.fullmatch(r"[-+]?\d+", text) else float(text)
    except ValueError:
        return text


def convert(idf_text):
    text = "\n".join(line.split("!")[0] for line in idf_text.splitlines())
    model = {}
    version = (99, 0)
    for obj in text.split(";"):
        fields = [f.strip() for f in obj.split(",")]
        if not fields[0]:
            continue
        cls, fields = fields[0], fields[1:]
        if cls not in FIELDS:
            continue
        names = FIELDS[cls]
        if cls == "Version":
            version = tuple(int(p) for p in fields[0].split(".")[:2])
        if cls == "FenestrationSurface:Detailed" and version < (9, 0):
            # Before EnergyPlus 9.0 a Shading Control Name came after the view factor to
            # ground; epJSON (9.0 and later) has none: shading controls name their windows.
            fields = fields[:6] + fields[7:]
        if cls in ("Window", "GlazedDoor") and version < (9, 0):
            fields = fields[:3] + fields[4:]  # the same field, after the base surface name
        if cls in UNNAMED:
            name = "%s 1" % cls
        else:
            name, fields = fields[0], fields[1:]
        out = {}
        for k, f in enumerate(fields[:len(names)]):
            if f:
                out[names[k]] = value(f) if names[k] != "version_identifier" else f
        coords = [float(c) for c in fields[len(names):]] if cls in WITH_VERTICES else []
        points = [coords[k:k + 3] for k in range(0, len(coords), 3)]
        if cls == "FenestrationSurface:Detailed":
            for k, p in enumerate(points):
                for axis, c in zip("xyz", p):
                    out["vertex_%d_%s_coordinate" % (k + 1, axis)] = c
        elif points:
            out["vertices"] = [{"vertex_%s_coordinate" % a: c for a, c in zip("xyz", p)}
                               for p in points]
        model.setdefault(cls, {})[name] = out
    return model


if __name__ == "__main__":
    with open(sys.argv[1]) as f:
        model = convert(f.read())
    with open(sys.argv[2], "w") as f:
        json.dump(model, f, indent=2)
        f.write("\n")
