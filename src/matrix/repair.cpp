#include "formfactor/matrix/repair.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"

namespace formfactor {

RepairMode parse_repair_mode(const std::string& name) {
    return enum_from_name(kRepairModeNames, name, "repair", "repair");
}

std::string to_string(RepairMode mode) { return enum_to_name(kRepairModeNames, mode); }

namespace {

// G = A F → ½(G + Gᵀ), negatives and the diagonal cleared.
void symmetrise(DenseMatrix& F, const std::vector<double>& A, RepairReport& rep) {
    const Eigen::Index n = F.rows();
    // O(N²) on one thread, a column walk: a signal must not wait for the end.
    const CancellationFlag& cancel = current_cancellation();
    for (Eigen::Index i = 0; i < n; ++i) {
        cancel.throw_if_requested();
        if (F(i, i) != 0.0) rep.diagonal_cleared = true;
        F(i, i) = 0.0;
        const double ai = A[static_cast<std::size_t>(i)];
        for (Eigen::Index j = i + 1; j < n; ++j) {
            const double aj = A[static_cast<std::size_t>(j)];
            double fij = F(i, j), fji = F(j, i);
            if (fij < 0.0) {
                fij = 0.0;
                ++rep.negatives_cleared;
            }
            if (fji < 0.0) {
                fji = 0.0;
                ++rep.negatives_cleared;
            }
            const double g = 0.5 * (ai * fij + aj * fji);
            F(i, j) = g / ai;
            F(j, i) = g / aj;
        }
    }
}

// y = F d, rows in parallel.
void multiply(const DenseMatrix& F, const Eigen::VectorXd& d, Eigen::VectorXd& y) {
    const Eigen::Index n = F.rows();
    constexpr Eigen::Index kBlock = 32;
    const auto blocks = static_cast<std::size_t>((n + kBlock - 1) / kBlock);
    parallel_for(blocks, 0, [&](std::size_t b) {
        const Eigen::Index lo = static_cast<Eigen::Index>(b) * kBlock;
        const Eigen::Index hi = std::min(n, lo + kBlock);
        for (Eigen::Index i = lo; i < hi; ++i) y(i) = F.row(i).dot(d);
    });
}

void close_rows(DenseMatrix& F, const RepairOptions& o, RepairReport& rep) {
    const Eigen::Index n = F.rows();
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n), y(n);
    std::vector<char> active(static_cast<std::size_t>(n), 1);
    for (Eigen::Index i = 0; i < n; ++i)
        if (!(F.row(i).maxCoeff() > 0.0)) {
            active[static_cast<std::size_t>(i)] = 0;
            ++rep.rows_not_closable;
        }
    double best = std::numeric_limits<double>::infinity();
    int since_best = 0;
    int it = 0;
    double defect = 0.0;
    for (;; ++it) {
        current_cancellation().throw_if_requested();
        multiply(F, d, y);
        defect = 0.0;
        for (Eigen::Index i = 0; i < n; ++i)
            if (active[static_cast<std::size_t>(i)])
                defect = std::max(defect, std::abs(d(i) * y(i) - 1.0));
        if (defect <= o.closure_tolerance || it >= o.max_iterations) break;
        // Stagnation at the rounding level: stop rather than spin.
        if (defect < best * 0.999) {
            best = defect;
            since_best = 0;
        } else if (++since_best > 50) {
            break;
        }
        for (Eigen::Index i = 0; i < n; ++i)
            if (active[static_cast<std::size_t>(i)] && y(i) > 0.0) d(i) = std::sqrt(d(i) / y(i));
    }
    const CancellationFlag& cancel = current_cancellation();
    for (Eigen::Index i = 0; i < n; ++i) {
        cancel.throw_if_requested();
        for (Eigen::Index j = 0; j < n; ++j) F(i, j) *= d(i) * d(j);
    }
    rep.closure_iterations = it;
    // Row sums of the scaled matrix, as stored.
    double final_defect = 0.0;
    for (Eigen::Index i = 0; i < n; ++i)
        if (active[static_cast<std::size_t>(i)])
            final_defect = std::max(final_defect, std::abs(F.row(i).sum() - 1.0));
    rep.closure_residual = final_defect;
    if (final_defect > 1e-9)
        rep.warnings.push_back(
            fmt::format("closure stopped after {} iterations with max |row sum - 1| = {:.3g}", it,
                        final_defect));
    if (rep.rows_not_closable > 0)
        rep.warnings.push_back(fmt::format(
            "{} row(s) see nothing (all zero): they cannot be closed and were left as they are",
            rep.rows_not_closable));
}

}  // namespace

RepairReport repair(DenseMatrix& F, const std::vector<double>& areas,
                    const RepairOptions& options) {
    const Eigen::Index n = F.rows();
    if (F.cols() != n || static_cast<Eigen::Index>(areas.size()) != n)
        throw Error(
            fmt::format("repair: {}x{} matrix with {} areas", F.rows(), F.cols(), areas.size()));
    RepairReport rep;
    rep.mode = options.mode;
    rep.before = diagnose(F, areas);
    if (options.mode == RepairMode::none) {
        rep.after = rep.before;
        return rep;
    }
    if (rep.before.nonfinite_entries > 0)
        throw Error(fmt::format("repair: the matrix has {} non-finite entries",
                                rep.before.nonfinite_entries));
    for (Eigen::Index i = 0; i < n; ++i)
        if (!(areas[static_cast<std::size_t>(i)] > 0.0))
            throw Error(
                fmt::format("repair: patch {} has area {}", i, areas[static_cast<std::size_t>(i)]));
    const bool closing = options.mode == RepairMode::closure || options.mode == RepairMode::both;
    if (closing && n > 0) {
        const bool looks_open = rep.before.row_sum_min < 1.0 - kOpenRowSum;
        if (looks_open && !options.enclosure && !options.force_closure)
            throw OptionError(
                "repair",
                fmt::format("the scene is open (row sums down to {:.6g}, radiation escapes): "
                            "closing its rows would invent exchange; use `repair` reciprocity, "
                            "or `force_closure` if the scene really is a closed enclosure",
                            rep.before.row_sum_min));
        if (looks_open)
            rep.warnings.push_back(fmt::format(
                "closing rows of a matrix whose row sums go down to {:.6g}{}",
                rep.before.row_sum_min,
                options.enclosure ? " (the scene is a declared enclosure)" : " (forced)"));
        else if (!options.enclosure)
            rep.warnings.push_back(
                "the scene is not declared an enclosure, but every row sum is within 1% of 1: "
                "closing them");
    }
    const DenseMatrix original = F;
    symmetrise(F, areas, rep);
    if (closing) close_rows(F, options, rep);
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j) {
            const double a = original(i, j), b = F(i, j);
            const double change = std::abs(b - a);
            rep.max_abs_change = std::max(rep.max_abs_change, change);
            if (a > 0.0) rep.max_relative_change = std::max(rep.max_relative_change, change / a);
        }
    rep.after = diagnose(F, areas);
    if (rep.after.entries_above_one > 0)
        rep.warnings.push_back(
            fmt::format("{} entries exceed 1 after the repair", rep.after.entries_above_one));
    if (rep.negatives_cleared > 0)
        rep.warnings.push_back(
            fmt::format("{} negative entries were set to 0", rep.negatives_cleared));
    return rep;
}

}  // namespace formfactor
