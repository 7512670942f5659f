#pragma once
/// The radiosity equation of computer graphics, B = E + ρ F B, per colour channel (R, G, B):
/// Goral, Torrance, Greenberg & Battaile 1984; Cohen & Wallace 1993, ch. 2 and 5.

#include "formfactor/core/types.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/hierarchical.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/solver.h"

namespace formfactor {

/// Where the emitted power goes, per channel (power = exitance × area, e.g. W for W/m² and m²).
/// With reciprocity, emitted = absorbed + escaped exactly at the solution.
struct RadiosityBalance {
    Rgb emitted = Rgb::Zero();   ///< Σ A_i E_i
    Rgb absorbed = Rgb::Zero();  ///< Σ A_i (1 − ρ_i) H_i, H_i = Σ_j F_ij B_j the irradiance
    Rgb escaped = Rgb::Zero();   ///< Σ A_i (1 − Σ_j F_ij) B_i, leaving an open scene
    /// max over channels of |emitted − absorbed − escaped| / emitted (0 without emission).
    double relative_defect = 0.0;
};

/// The solution: radiosity B per patch (same units as the emission), and the solve's report.
struct RadiosityResult {
    std::vector<Rgb> radiosity;
    SolverStats stats;
    RadiosityBalance balance;
};

/// Solves B = E + diag(ρ) F B for each channel with the chosen solver. F must be square with
/// ff.areas of the same size and props.size() rows. Throws Error on a size mismatch, and on
/// non-convergence when options.fail_if_not_converged.
RadiosityResult solve_radiosity(const FormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options = {});

/// The same solve on the hierarchical operator (products only: options.solver must be gmres or
/// jacobi, OptionError "solver" otherwise).
RadiosityResult solve_radiosity(const HierarchicalFormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options);

/// The same solve on a sparse F (CSR, formfactor/matrix/sparse.h): options.solver gauss-seidel
/// (sweeps over the stored entries), gmres or jacobi; direct and shooting need the dense F
/// (OptionError "solver"). The balance's `escaped` counts what the stored entries do not carry,
/// the threshold's dropped mass included (a conservative repair puts it back).
RadiosityResult solve_radiosity(const SparseFormFactors& ff, const PatchProperties& props,
                                const SolverOptions& options);
/// The energy balance of a radiosity solution B (see RadiosityBalance).
RadiosityBalance radiosity_balance(const FormFactors& ff, const PatchProperties& props,
                                   const std::vector<Rgb>& radiosity, int threads = 0);

}  // namespace formfactor
