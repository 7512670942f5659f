#pragma once
/// What the radiosity and thermal solvers share: the choice of iterative or direct solver, its
/// stopping rule, and what it reports (DESIGN.md, "Solvers").
///
/// Both solvers reduce to one linear system per channel k,
///
///     x = c + diag(d_k) F x        i.e.  (I − diag(d_k) F) x = c,
///
/// with F the form-factor matrix (row i = from patch i), d_k the reflectance of channel k
/// (radiosity) or 1 − ε (thermal, known temperature) or 1 (thermal, known flux).
///
/// Residual: the relative residual of x is ‖c + diag(d) F x − x‖_∞ / ‖x‖_∞, the largest
/// absolute entry over patches and channels divided by the largest |x| (0 when x = 0).

#include <cstddef>
#include <string>
#include <vector>

#include "formfactor/core/enum_names.h"
#include "formfactor/core/progress.h"

namespace formfactor {

/// The solver of the linear system.
enum class SolverKind {
    jacobi,        ///< x ← c + D F x, rows in parallel (a dense matrix-vector product per sweep)
    gauss_seidel,  ///< in-place sweeps in patch order (sequential, usually ~2× fewer sweeps)
    shooting,      ///< progressive refinement (Cohen, Chen, Wallace & Greenberg 1988): shoot
                   ///< the patch with the most unshot power A_i·|Δx_i| (Southwell order);
                   ///< reads columns of F (a transposed copy, N² doubles, up to 8192 patches)
    direct,        ///< LU with partial pivoting of I − D F (Eigen), O(N³): the reference
    gmres,         ///< restarted GMRES(30) on I − D F, one product with F per iteration (Saad &
                   ///< Schultz 1986): the solver of operators that are never formed (the
                   ///< hierarchical operator), few products where Jacobi needs many (small ε)
};

/// The names of the solvers (then accepted aliases).
inline constexpr EnumEntry<SolverKind> kSolverNames[] = {
    {SolverKind::jacobi, "jacobi"},        {SolverKind::gauss_seidel, "gauss-seidel"},
    {SolverKind::shooting, "shooting"},    {SolverKind::direct, "direct"},
    {SolverKind::gmres, "gmres"},          {SolverKind::gauss_seidel, "gauss_seidel"},
    {SolverKind::shooting, "progressive"}, {SolverKind::direct, "lu"},
};

/// Parses jacobi | gauss-seidel | shooting | direct | gmres (and the aliases); throws
/// OptionError("solver") otherwise.
SolverKind parse_solver(const std::string& name);
/// The name parse_solver() accepts.
std::string to_string(SolverKind kind);

/// Stopping rule and resources of a solve.
struct SolverOptions {
    SolverKind solver = SolverKind::gauss_seidel;
    /// Stop when the relative residual (∞-norm, see above) is below this.
    double residual = 1e-8;
    /// Sweeps (jacobi, gauss-seidel), shots (shooting) or products (gmres, summed over the
    /// channels); 0 = automatic (10000 sweeps, 10000·N shots, 1000 products per channel).
    long long max_iterations = 0;
    /// Threads for the parallel products (0 = all cores).
    int threads = 0;
    /// When the limit is reached before the tolerance: true throws formfactor::Error, false
    /// returns the current estimate with converged = false and a warning.
    bool fail_if_not_converged = true;
    /// Shooting only: add the ambient term ρ_i·ambient of Cohen et al. 1988 to the returned
    /// estimate (a preview of the still-unshot light). Off for exact answers.
    bool add_ambient = false;
    /// Where the solve reports its progress (sweeps, shots or products done of the limit);
    /// null (the default): nowhere.
    ProgressSink* progress = nullptr;
};

/// The N × N double matrices a solve with `kind` allocates besides F, named (for the memory
/// estimate, formfactor/matrix/memory.h): direct: the system matrix and its LU factors;
/// shooting: the transposed copy of F (up to 8192 patches); jacobi, gauss-seidel: none.
std::vector<std::string> solver_dense_matrices(SolverKind kind, std::size_t n);

/// The N × N matrices total_exchange_factors() allocates besides F (system, LU, result).
std::vector<std::string> exchange_factor_dense_matrices();

/// What a solve reports.
struct SolverStats {
    std::string solver;           ///< to_string(kind)
    long long iterations = 0;     ///< sweeps (jacobi, gauss-seidel), shots (shooting), 1 (direct),
                                  ///< products with F (gmres)
    double residual = 0.0;        ///< final relative residual, recomputed from scratch
    double tolerance = 0.0;       ///< the requested one
    bool converged = true;        ///< residual ≤ tolerance
    double seconds = 0.0;         ///< wall time of the solve
    std::vector<double> ambient;  ///< shooting: the ambient term per channel at the stop
    std::vector<std::string> warnings;
};

}  // namespace formfactor
