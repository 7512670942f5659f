#pragma once
// The check of a PLY file that comes before Open Asset Import reads it (src/scene/ply_check.cpp).

#include <string>

namespace formfactor::detail {

/// Reads the PLY file at `path` as the format describes it (Turk's PLY: a text header of
/// `format`, `element`, `property` and `comment` lines ending in `end_header`, then the data in
/// ASCII, one element instance per line, or in little- or big-endian binary) and throws
/// InputError(path, line, ...) at the first thing that is wrong: a header that never ends, a
/// line of the header that is not part of its grammar, an unknown type, a property outside an
/// element, a repeated name, an element Open Asset Import does not know (not vertex, face,
/// tristrips, edge or material) with data before one it does, or named with a leading digit
/// (it reads the count from the name), a count that the data cannot hold, an ASCII line whose words
/// do not match its element's properties or that holds a word its type cannot take, data that ends
/// early or goes on past what the header declares.
///
/// Open Asset Import 5.2.5 loops forever on a header without `end_header`, leaks on some damaged
/// ASCII data and reads others as zeros; a file that passes this check is one it reads as the
/// header declares.
void check_ply(const std::string& path);

}  // namespace formfactor::detail
