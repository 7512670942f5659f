#pragma once
/// Per-patch tables: what row/column i of the matrix is; and the long (pairwise) table of a
/// named matrix.

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Writes one CSV line per patch, with the header
/// `patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz`: the 0-based patch index (= matrix row),
/// the 0-based index and name of the surface it came from, its area, centroid and unit front
/// normal (`%.17g`). Names are quoted when they contain a comma or a quote.
void write_patch_table(std::ostream& out, const Scene& scene);

/// The same table with two more columns, `row_sum,sky_factor`: Σ_j F_ij and 1 − Σ_j F_ij of
/// each patch (`row_sums[i]`). Throws Error when row_sums does not have one value per patch.
void write_patch_table(std::ostream& out, const Scene& scene, const std::vector<double>& row_sums);

/// write_patch_table() into `path`, atomically.
void write_patch_table(const std::string& path, const Scene& scene);

/// The long form of a matrix whose rows and columns are named (per-surface F): the header
/// `from,to,F`, then one line per pair (i, j), row-major, every pair (zeros too), names quoted as
/// above, values `%.17g`. Throws Error when names and F disagree in size.
void write_pairs_csv(std::ostream& out, const std::vector<std::string>& names,
                     const DenseMatrix& F);

}  // namespace formfactor
