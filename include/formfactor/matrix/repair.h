#pragma once
/// Repair of a computed form-factor matrix (DESIGN.md, "Repair and diagnostics"): enforce
/// reciprocity A_i F_ij = A_j F_ji, then closure Σ_j F_ij = 1 in a closed enclosure, without
/// breaking reciprocity, keeping F_ii = 0 and F ≥ 0.
///
/// - reciprocity: G = A F (G_ij = A_i F_ij, the "exchange areas") is replaced by its symmetric
///   part ½(G + Gᵀ), negative entries and the diagonal are set to 0, F = A⁻¹ G.
/// - closure: after the reciprocity step, a symmetric diagonal scaling G ← D G D
///   (G_ij ← d_i G_ij d_j) with D chosen so that every row of G sums to A_i, i.e. every row
///   of F to 1. D is found by the symmetric Sinkhorn–Knopp iteration d_i ← √(d_i A_i / (G d)_i)
///   (Knight, Ruiz & Uçar 2014), in the spirit of View3D's enclosure adjustment and the
///   smoothing of Truchas / ANSYS VFSM. Since G_ij/A_i = F_ij, the iteration needs only F:
///   d_i ← √(d_i / Σ_j F_ij d_j), then F_ij ← d_i F_ij d_j. Entries move by factors d_i d_j,
///   so zeros stay zero and reciprocity stays exact. Rows that see nothing are left alone.
///   Memory: one extra copy of F (to report how far entries moved).
/// - both: reciprocity then closure. `closure` alone implies the reciprocity step too (a
///   symmetric scaling needs a symmetric G).
///
/// Closure is refused for an open scene (RepairOptions::enclosure false and some row sum below
/// 1 − kOpenRowSum) unless forced: it would invent energy exchange where radiation escapes.

#include <string>
#include <vector>

#include "formfactor/core/enum_names.h"
#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// Which repair to apply.
enum class RepairMode { none, reciprocity, closure, both };

inline constexpr EnumEntry<RepairMode> kRepairModeNames[] = {
    {RepairMode::none, "none"},
    {RepairMode::reciprocity, "reciprocity"},
    {RepairMode::closure, "closure"},
    {RepairMode::both, "both"},
};

/// Parses none | reciprocity | closure | both; throws OptionError("repair") otherwise.
RepairMode parse_repair_mode(const std::string& name);
/// The name parse_repair_mode() accepts.
std::string to_string(RepairMode mode);

/// A row sum below 1 − kOpenRowSum marks a scene as open (radiation escapes).
inline constexpr double kOpenRowSum = 0.01;

/// Options of repair().
struct RepairOptions {
    RepairMode mode = RepairMode::none;
    /// True when the scene is known to be a closed enclosure (the pipeline passes
    /// known_enclosure(): declared, or a closed model).
    bool enclosure = false;
    /// Close the rows even when the matrix looks open.
    bool force_closure = false;
    /// Stop the closure iteration when max |row sum − 1| ≤ this.
    double closure_tolerance = 1e-13;
    int max_iterations = 10000;
};

/// What repair() did, for the report.
struct RepairReport {
    RepairMode mode = RepairMode::none;
    Diagnostics before, after;
    double max_abs_change = 0.0;        ///< max |F'_ij − F_ij|
    double max_relative_change = 0.0;   ///< max |F'_ij − F_ij| / F_ij over F_ij > 0
    std::size_t negatives_cleared = 0;  ///< negative entries set to 0
    bool diagonal_cleared = false;      ///< some F_ii ≠ 0 was set to 0
    int closure_iterations = 0;
    double closure_residual = 0.0;      ///< max |row sum − 1| after closure (rows that can close)
    std::size_t rows_not_closable = 0;  ///< rows that see nothing (all zero): left as they are
    std::vector<std::string> warnings;
};

/// Repairs F in place (see above). Throws OptionError("repair") when closure is asked of an
/// open scene without force_closure, and Error on a size mismatch. With mode none, only the
/// diagnostics are filled.
RepairReport repair(DenseMatrix& F, const std::vector<double>& areas, const RepairOptions& options);

}  // namespace formfactor
