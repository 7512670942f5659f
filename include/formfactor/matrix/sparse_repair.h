#pragma once
/// Conservative repair of a thresholded sparse F (formfactor/matrix/sparse.h): reciprocity on a
/// symmetric pattern, and closure in a closed enclosure, without creating energy.
///
/// 1. Pattern and exchange areas. G_ij = A_i F_ij (the exchange area, which reciprocity makes
///    symmetric). The pattern becomes the union of the stored pattern and its transpose: when
///    F_ij is stored and F_ji was dropped (it fell below the threshold, e.g. because A_j > A_i),
///    F_ji is restored as A_i F_ij / A_j (the dropped mass of row j held it). A pair stored both
///    ways gets the mean ½(G_ij + G_ji). The diagonal and entries ≤ 0 are removed.
/// 2. Scaling. The new G is D G D (G_ij ← d_i d_j G_ij), which keeps it symmetric, so
///    A_i F_ij = A_j F_ji holds to rounding (~1e-16 relative), and keeps the pattern.
///    - Open scene (no closure): no row may end above its computed row sum c_i (the method's
///      Σ_j F_ij before the threshold, SparseFormFactors::computed_row_sums): energy that
///      escapes stays escaped. One Gauss–Seidel sweep over the rows, each row above its cap
///      gets d_i ← d_i · c_i / (its current sum); later rows only lower d, so every row ends
///      ≤ its cap (checked after, with a correction pass for rounding). d ≤ 1: entries only
///      shrink from their symmetrised values.
///    - Closed scene (closure): the symmetric Sinkhorn–Knopp iteration
///      d_i ← √(d_i / Σ_j F_ij d_j) (Knight, Ruiz & Uçar 2014, as the dense repair()) until
///      max |row sum − 1| ≤ closure_tolerance: the dropped mass goes back to the stored entries
///      of the row, proportionally. Rows without entries are left alone.
/// Per-entry standard errors are removed (they described the unrepaired estimates).

#include <cstddef>

#include "formfactor/matrix/sparse.h"

namespace formfactor {

/// Options of repair(SparseFormFactors&, ...).
struct SparseRepairOptions {
    /// Close the rows to 1 (the scene is a closed enclosure); otherwise the open-scene rule
    /// (row sums never above their computed values).
    bool closure = false;
    /// Closure: stop when max |row sum − 1| ≤ this.
    double closure_tolerance = 1e-13;
    int max_iterations = 10000;
};

/// What the sparse repair did.
struct SparseRepairReport {
    bool closure = false;
    SparseDiagnostics before, after;
    std::size_t entries_restored = 0;  ///< reverse entries added to make the pattern symmetric
    std::size_t entries_removed = 0;   ///< diagonal or ≤ 0 entries removed
    std::size_t rows_lowered = 0;      ///< open scene: rows scaled down to their computed sum
    double min_scale = 1.0;            ///< smallest d_i
    int closure_iterations = 0;
    double closure_residual = 0.0;      ///< max |row sum − 1| over closable rows after closure
    std::size_t rows_not_closable = 0;  ///< rows without entries
    /// Largest row sum minus its computed value (≤ 0 in an open scene).
    double max_row_increase = 0.0;
};

/// Repairs F in place (see above): afterwards F.dropped[i] = computed_row_sums[i] − row sum
/// (negative where closure raised a row). Throws Error on inconsistent arrays.
SparseRepairReport repair(SparseFormFactors& F, const SparseRepairOptions& options);

}  // namespace formfactor
