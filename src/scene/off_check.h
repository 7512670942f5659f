#pragma once
// The check of an OFF file that comes before Open Asset Import reads it (src/scene/off_check.cpp).

#include <string>

namespace formfactor::detail {

/// Reads the OFF file at `path` as Open Asset Import 5.2.5 will and throws InputError(path, line,
/// ...) wherever that reader would go wrong:
/// - the header: the keyword `[ST][C][N][4][n]OFF` (`n`: a dimension of 1 to 3 follows), then
///   the counts of vertices, faces and edges on one line (`#` starts a comment); a count that is
///   not a whole number below 2³¹, no vertices or no faces, or more vertices and faces than the
///   file has lines left to hold. assimp allocates what the counts declare before it reads a line
///   (10¹¹ faces in a file of 100 bytes asked for 15 GB); without a keyword or the edges' count
///   it misreads the header or the first vertex.
/// - the data: one line per vertex, its coordinates numbers; one line per face, 1 to 9 vertex
///   indices each below the count of vertices; no blank or comment line between them, no line of
///   4,095 bytes or more, no NUL byte. assimp reads a blank line as a vertex at the origin and a
///   word that is not a number as 0, drops faces of 0 or more than 9 vertices (and crashed when
///   that left none), clamps indices, and copies each line into 4,096 bytes.
void check_off(const std::string& path);

}  // namespace formfactor::detail
