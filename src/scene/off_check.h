#pragma once
// The check of an OFF file that comes before Open Asset Import reads it (src/scene/off_check.cpp).

#include <string>

namespace formfactor::detail {

/// Reads the header of the OFF file at `path` (an optional keyword `[ST][C][N][4][n]OFF`, for
/// `n` a dimension, then the counts of vertices, faces and, optionally, edges; `#` starts a
/// comment) and throws InputError(path, line, ...) when it is not one: no counts, a count that
/// is not a whole number, no vertices or no faces, or more vertices and faces than the file has
/// lines left to hold them (each vertex and each face takes a line of its own).
///
/// Open Asset Import 5.2.5 reads the counts into 32-bit integers without a check and allocates
/// the faces and vertices they declare before it reads a line of data: a count of 10¹¹ written
/// into a file of 100 bytes asks for 15 GB. After this check an import allocates at most a
/// few dozen bytes per line of the file.
void check_off(const std::string& path);

}  // namespace formfactor::detail
