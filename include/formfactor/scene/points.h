#pragma once
/// Differential elements read from a file: points with a front normal (sensors, radiometers, the
/// points of a mean-radiant-temperature map) for point_form_factors().

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor {

/// Points with unit front normals, in file order, and the line each came from.
struct PointElements {
    std::vector<Vec3> positions;
    std::vector<Vec3> normals;  ///< unit length
    std::vector<int> lines;     ///< 1-based line of each point in its file
};

/// Reads a point file: one point per line, `x,y,z,nx,ny,nz` (six numbers separated by commas, or
/// by spaces or tabs when the line has no comma). `#` starts a comment (whole line or the rest
/// of it); blank lines are skipped; the first line with content may be a header (its first
/// field is not a number, e.g. `x,y,z,nx,ny,nz`) and must then have six fields. Coordinates must
/// be finite; the normal must be finite and not zero, and is normalised. Throws
/// InputError(name, line, reason) for a bad line and InputError(name, 0, ...) for a file without
/// points.
PointElements parse_points_csv(std::istream& in, const std::string& name);

/// parse_points_csv() of the file at `path` (InputError(path, 0, "cannot open file") when it
/// cannot be read).
PointElements read_points_csv(const std::string& path);

}  // namespace formfactor
