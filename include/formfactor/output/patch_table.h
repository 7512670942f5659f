#pragma once
/// Per-patch tables: what row/column i of the matrix is.

#include <iosfwd>
#include <string>

#include "formfactor/scene/scene.h"

namespace formfactor {

/// Writes one CSV line per patch, with the header
/// `patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz`: the 0-based patch index (= matrix row),
/// the 0-based index and name of the surface it came from, its area, centroid and unit front
/// normal (`%.17g`). Names are quoted when they contain a comma or a quote.
void write_patch_table(std::ostream& out, const Scene& scene);

/// write_patch_table() into `path`, atomically.
void write_patch_table(const std::string& path, const Scene& scene);

}  // namespace formfactor
