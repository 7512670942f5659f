#pragma once
/// Radiative heat exchange between grey diffuse surfaces (the net-radiation method; Modest,
/// *Radiative Heat Transfer*, ch. 5; Siegel & Howell). Each patch has an emissivity ε and
/// either a temperature T (K) or a prescribed net flux q (W/m², leaving the patch). Unknowns
/// are the radiosities J (W/m²), one linear system:
///
///     known T:  J_i − (1 − ε_i) Σ_j F_ij J_j = ε_i σ T_i⁴ + (1 − ε_i) (1 − s_i) σ T_env⁴
///     known q:  J_i −           Σ_j F_ij J_j = q_i         +           (1 − s_i) σ T_env⁴
///
/// with s_i = Σ_j F_ij. The irradiation is H_i = Σ_j F_ij J_j + (1 − s_i) σ T_env⁴: in an open
/// scene the missing part of each row sees the environment, a black body at T_env (default
/// 0 K, i.e. radiation that escapes is lost). Then q_i = J_i − H_i (net flux leaving i; equal
/// to ε_i/(1 − ε_i)(σT_i⁴ − J_i) for ε_i < 1; ε = 1 gives J_i = σT_i⁴ exactly), and for a
/// known-q patch σT_i⁴ = J_i + q_i (1 − ε_i)/ε_i.
///
/// A patch with neither T nor q is treated as adiabatic (re-radiating, q = 0), with a warning.

#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/hierarchical.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/solver.h"

namespace formfactor {

/// Options of the thermal solve.
struct ThermalOptions {
    /// The linear solver (direct by default: thermal systems are small and may be stiff when
    /// ε is small).
    SolverOptions solver = {SolverKind::direct};
    /// Temperature of the environment that the open part of each row sees, K (≥ 0).
    double ambient_temperature = 0.0;
    /// The scene is known to be closed (a closed model, formfactor/scene/closure.h, or a
    /// declared enclosure): no radiation can leave it, so a row that sums to less than 1 is an
    /// error of the estimate, not a view of the environment. Then the missing part 1 − s_i of
    /// each row sees the patch's own radiosity J_i instead of σ T_env⁴ (as if F_ii held it):
    /// nothing is exchanged with the environment (escaped_power is 0) and energy is conserved
    /// for a reciprocal F; a warning states the lowest row sum instead of calling the scene
    /// open, and a solve whose patches all have a prescribed flux is refused as singular.
    bool closed = false;
};

/// Per-patch results (SI units when the scene is in metres) and the energy balance.
struct ThermalResult {
    std::vector<double> area;         ///< m²
    std::vector<double> emissivity;   ///< ε
    std::vector<double> temperature;  ///< K (prescribed, or found from the solution; NaN when
                                      ///< the prescribed flux needs σT⁴ < 0)
    std::vector<bool> temperature_prescribed;
    std::vector<double> radiosity;  ///< J, W/m²
    std::vector<double> net_flux;   ///< q = J − H, W/m², positive = the patch loses heat
    std::vector<double> net_power;  ///< q·A, W
    double total_net_power = 0.0;   ///< Σ net_power, W
    /// Net power carried to the environment, Σ A_i (1 − s_i)(J_i − σ T_env⁴), W. In a closed
    /// enclosure 0, and always total_net_power = escaped_power at the solution.
    double escaped_power = 0.0;
    /// |total_net_power − escaped_power| / Σ |net_power| (0 when nothing flows).
    double relative_balance_defect = 0.0;
    double ambient_temperature = 0.0;
    /// Solved as a closed model (ThermalOptions::closed): nothing exchanged with the environment.
    bool closed = false;
    SolverStats stats;
    std::vector<std::string> warnings;
};

/// Solves the system above. Throws Error when the system is singular (every patch has a
/// prescribed flux and the enclosure is closed: temperatures are then defined only up to a
/// constant), on size mismatches, and on non-convergence when the options ask for it.
ThermalResult solve_thermal(const FormFactors& ff, const PatchProperties& props,
                            const ThermalOptions& options = {});

/// The same solve on the hierarchical operator (products only: options.solver must be gmres or
/// jacobi, OptionError "solver" otherwise).
ThermalResult solve_thermal(const HierarchicalFormFactors& ff, const PatchProperties& props,
                            const ThermalOptions& options);

/// The same solve on a sparse F (CSR): options.solver gmres, jacobi or gauss-seidel (direct
/// and shooting need the dense F: OptionError "solver"). Row sums are those of the stored
/// entries: what a threshold dropped is seen as environment (a warning says how much; a
/// conservative repair, formfactor/matrix/sparse_repair.h, puts it back), and a closed room is
/// told from an open scene within twice the largest dropped mass of a row.
ThermalResult solve_thermal(const SparseFormFactors& ff, const PatchProperties& props,
                            const ThermalOptions& options);
/// Hottel's total exchange factors 𝓕 (script-F) for grey diffuse surfaces:
///
///     𝓕 = diag(ε) · F · (I − diag(1 − ε) F)⁻¹ · diag(ε)
///
/// 𝓕_ij is the fraction of the power emitted by a black body at i's temperature over A_i that
/// is absorbed by j after any number of diffuse reflections: the emission of i is ε_i A_i σT⁴;
/// G = F (I − diag(1 − ε) F)⁻¹ sums the paths i → j directly (F) and via reflections, and j
/// absorbs ε_j of what arrives. So the net exchange is Q_ij = A_i 𝓕_ij σ (T_i⁴ − T_j⁴),
/// A_i 𝓕_ij = A_j 𝓕_ji when A F is symmetric, and Σ_j 𝓕_ij = ε_i in a closed enclosure. For
/// two infinite parallel plates 𝓕_12 = 1 / (1/ε1 + 1/ε2 − 1). With every ε = 1, 𝓕 = F.
/// Cost O(N³) (an LU of I − F diag(1 − ε)).
DenseMatrix total_exchange_factors(const DenseMatrix& F, const std::vector<double>& emissivity);

}  // namespace formfactor
