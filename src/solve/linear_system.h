#pragma once
// The engine behind solve_radiosity and solve_thermal: x = c + diag(d_k) F x per column k.

#include <Eigen/Core>
#include <Eigen/LU>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/solve/solver.h"

namespace formfactor::detail {

/// n×k, column-major: one column per channel (contiguous per channel for the dot products).
using Columns = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;

/// Solves x = c + diag(d.col(k)) F x for every column k with options.solver. `areas` weights
/// the shooting order (A_i |r_i|) and the ambient term. x is resized to c's shape.
SolverStats solve_linear(const DenseMatrix& F, const std::vector<double>& areas, const Columns& d,
                         const Columns& c, const SolverOptions& options, Columns& x);

/// y = F x for an operator that is never formed (the hierarchical operator).
using ApplyF = std::function<void(const Columns& x, Columns& y)>;

/// solve_linear on an operator: jacobi or gmres (the others need F's entries: OptionError
/// "solver").
SolverStats solve_linear_operator(const ApplyF& apply, Eigen::Index n, const Columns& d,
                                  const Columns& c, const SolverOptions& options, Columns& x);

/// y = F x, rows in parallel (no allocation when y already has x's shape).
void multiply(const DenseMatrix& F, const Columns& x, Columns& y, int threads);

/// ‖c + D F x − x‖_∞ / ‖x‖_∞ (0 when x = 0); `work` is scratch of x's shape.
double relative_residual(const DenseMatrix& F, const Columns& d, const Columns& c, const Columns& x,
                         Columns& work, int threads);

/// Eigen's LU of M, which cannot be stopped part-way (a minute at N = 10⁴): it runs on a thread of
/// its own while the caller polls current_cancellation(). When a stop is asked, Cancelled is
/// thrown at once and the abandoned thread finishes on data only it holds, then ends.
std::shared_ptr<const Eigen::PartialPivLU<DenseMatrix>> interruptible_lu(DenseMatrix M);

/// Throws Error unless F is n×n with n areas and n patch properties.
void check_sizes(const FormFactors& ff, std::size_t properties);

/// y = F x for a CSR matrix: rows in fixed chunks in parallel, each row's entries summed in
/// column order (bit-identical for any thread count).
void multiply(const SparseFormFactors& F, const Columns& x, Columns& y, int threads);

/// solve_linear on a CSR matrix: gauss-seidel (sweeps over the stored entries), jacobi or
/// gmres (products); direct and shooting need the dense F (OptionError "solver").
SolverStats solve_linear(const SparseFormFactors& F, const Columns& d, const Columns& c,
                         const SolverOptions& options, Columns& x);

/// The largest dropped mass of a row (F.dropped; 0 when none is positive).
double max_dropped(const SparseFormFactors& F);

/// A warning when the stored entries of some row carry less than the method computed (what a
/// threshold dropped and no repair put back, above 1e-9), which a solve sees as environment;
/// empty otherwise.
std::string dropped_mass_warning(const SparseFormFactors& F);

/// Throws OptionError("solver") for a solver that needs the dense F (direct, shooting).
void check_sparse_solver(SolverKind kind);

/// Throws Error unless the CSR matrix has n areas and n patch properties.
void check_sizes(const SparseFormFactors& F, std::size_t properties);

}  // namespace formfactor::detail
