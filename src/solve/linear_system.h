#pragma once
// The engine behind solve_radiosity and solve_thermal: x = c + diag(d_k) F x per column k.

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/solve/properties.h"
#include "formfactor/solve/radiosity.h"
#include "formfactor/solve/solver.h"
#include "formfactor/solve/thermal.h"

namespace formfactor::detail {

/// n×k, column-major: one column per channel (contiguous per channel for the dot products).
using Columns = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;

/// Solves x = c + diag(d.col(k)) F x for every column k with options.solver. `areas` weights
/// the shooting order (A_i |r_i|) and the ambient term. x is resized to c's shape.
SolverStats solve_linear(const DenseMatrix& F, const std::vector<double>& areas, const Columns& d,
                         const Columns& c, const SolverOptions& options, Columns& x);

/// One Gauss–Seidel update of row i of x = c + diag(d) F x, in place for every column, with
/// F_ii solved for: x_i = (c_i + d_i Σ_{j≠i} F_ij x_j) / (1 − d_i F_ii). `f` is row i of a dense
/// F (any Eigen row expression: its own summation order is kept). Returns the largest change.
template <class Row>
double gauss_seidel_row(Eigen::Index i, const Row& f, const Columns& d, const Columns& c,
                        Columns& x) {
    double change = 0.0;
    const double fii = f(i);
    for (Eigen::Index k = 0; k < x.cols(); ++k) {
        const double s = f.dot(x.col(k)) - fii * x(i, k);
        const double v = (c(i, k) + d(i, k) * s) / (1.0 - d(i, k) * fii);
        change = std::max(change, std::abs(v - x(i, k)));
        x(i, k) = v;
    }
    return change;
}

/// The same for a CSR row: its `count` stored entries (columns `indices`, ascending), the
/// diagonal among them when stored.
inline double gauss_seidel_row(Eigen::Index i, const std::int32_t* indices, const double* values,
                               std::size_t count, const Columns& d, const Columns& c, Columns& x) {
    double change = 0.0;
    for (Eigen::Index k = 0; k < x.cols(); ++k) {
        double s = 0.0, fii = 0.0;
        for (std::size_t e = 0; e < count; ++e) {
            const Eigen::Index j = indices[e];
            if (j == i)
                fii = values[e];
            else
                s += values[e] * x(j, k);
        }
        const double v = (c(i, k) + d(i, k) * s) / (1.0 - d(i, k) * fii);
        change = std::max(change, std::abs(v - x(i, k)));
        x(i, k) = v;
    }
    return change;
}

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

/// What the thermal solve needs of F: its size, areas and row sums, y = F x, and a solver of
/// x = c + diag(d) F x. Dense, sparse, an operator, or rows spread over MPI ranks.
struct ThermalSystem {
    Eigen::Index n = 0;
    const std::vector<double>* areas = nullptr;
    std::vector<double> row_sums;
    /// How far below 1 a row sum of a closed enclosure may come out: rounding for a dense F,
    /// the compression error for an operator.
    double row_sum_tolerance = 1e-9;
    ApplyF apply;  // y = F x
    std::function<SolverStats(const Columns& d, const Columns& c, Columns& x)> solve;
};

/// solve_thermal() on any ThermalSystem (formfactor/solve/thermal.h).
ThermalResult solve_thermal_system(const ThermalSystem& sys, const PatchProperties& props,
                                   const ThermalOptions& options);

/// The radiosity system of `props`: d = ρ and c = E, one column per channel.
void radiosity_system(const PatchProperties& props, Columns& d, Columns& c);

/// The energy balance of a radiosity solution B from H = F B and the row sums of F.
RadiosityBalance radiosity_balance_of(const std::vector<double>& areas,
                                      const std::vector<double>& row_sums,
                                      const PatchProperties& props, const Columns& B,
                                      const Columns& H);

}  // namespace formfactor::detail
