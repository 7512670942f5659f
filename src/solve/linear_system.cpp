#include "solve/linear_system.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <thread>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/phase.h"
#include "formfactor/core/progress.h"

namespace formfactor {

SolverKind parse_solver(const std::string& name) {
    return enum_from_name(kSolverNames, name, "solver", "solver");
}

std::string to_string(SolverKind kind) { return enum_to_name(kSolverNames, kind); }

namespace detail {

namespace {

constexpr Eigen::Index kRowBlock = 32;  // rows per parallel task: amortises the dispatch
constexpr Eigen::Index kShootingTransposeMax = 8192;

double max_abs(const Columns& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

}  // namespace

void multiply(const DenseMatrix& F, const Columns& x, Columns& y, int threads) {
    const Eigen::Index n = F.rows();
    const Eigen::Index k = x.cols();
    if (y.rows() != n || y.cols() != k) y.resize(n, k);
    const std::size_t blocks = static_cast<std::size_t>((n + kRowBlock - 1) / kRowBlock);
    auto body = [&](std::size_t b) {
        const Eigen::Index lo = static_cast<Eigen::Index>(b) * kRowBlock;
        const Eigen::Index hi = std::min(n, lo + kRowBlock);
        for (Eigen::Index i = lo; i < hi; ++i)
            for (Eigen::Index c = 0; c < k; ++c) y(i, c) = F.row(i).dot(x.col(c));
    };
    // Small systems: a thread hand-off costs more than the product.
    if (n * n < 64 * 64) {
        for (std::size_t b = 0; b < blocks; ++b) body(b);
    } else {
        parallel_for(blocks, threads, body);
    }
}

namespace {

// ‖c + D y − x‖_∞ / ‖x‖_∞ for y = F x (0 when x = 0).
double residual_of(const Columns& d, const Columns& c, const Columns& x, const Columns& y) {
    double r = 0.0;
    for (Eigen::Index k = 0; k < x.cols(); ++k)
        for (Eigen::Index i = 0; i < x.rows(); ++i)
            r = std::max(r, std::abs(c(i, k) + d(i, k) * y(i, k) - x(i, k)));
    const double xm = max_abs(x);
    if (xm == 0.0) return r == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
    return r / xm;
}

}  // namespace

double relative_residual(const DenseMatrix& F, const Columns& d, const Columns& c, const Columns& x,
                         Columns& work, int threads) {
    multiply(F, x, work, threads);
    return residual_of(d, c, x, work);
}

namespace {

// Runs sweeps (each returns its largest update) until the update is small and the exact
// relative residual (from `exact_residual()`) is below o.residual, or max_it sweeps; returns
// the sweep count.
template <class Sweep, class Residual>
long long iterate(const SolverOptions& o, long long max_it, Progress& progress, Columns& x,
                  double& residual, Sweep&& sweep, Residual&& exact_residual) {
    long long it = 0;
    const CancellationFlag& cancel = current_cancellation();
    while (it < max_it) {
        cancel.throw_if_requested();
        const double change = sweep();
        ++it;
        progress.advance();
        const double xm = max_abs(x);
        if (change <= o.residual * xm || xm == 0.0) {
            residual = exact_residual();
            if (residual <= o.residual) return it;
        }
    }
    residual = exact_residual();
    return it;
}

// x ← c + D F x until the update (= the residual of the previous iterate) is below tolerance;
// `apply(x, y)` is y = F x (a dense product or an operator's).
template <class Apply>
long long run_jacobi(const Apply& apply, const Columns& d, const Columns& c, const SolverOptions& o,
                     long long max_it, Progress& progress, Columns& x, Columns& y,
                     double& residual) {
    return iterate(
        o, max_it, progress, x, residual,
        [&] {
            apply(x, y);
            double change = 0.0;
            for (Eigen::Index k = 0; k < x.cols(); ++k)
                for (Eigen::Index i = 0; i < x.rows(); ++i) {
                    const double v = c(i, k) + d(i, k) * y(i, k);
                    change = std::max(change, std::abs(v - x(i, k)));
                    x(i, k) = v;
                }
            return change;
        },
        [&] {
            apply(x, y);
            return residual_of(d, c, x, y);
        });
}

// In-place sweeps. In the ∞-norm the residual after a sweep is at most the largest update
// (row sums of D F ≤ 1), so a small update triggers the exact residual check.
long long run_gauss_seidel(const DenseMatrix& F, const Columns& d, const Columns& c,
                           const SolverOptions& o, long long max_it, Progress& progress, Columns& x,
                           Columns& y, double& residual) {
    const Eigen::Index n = F.rows();
    return iterate(
        o, max_it, progress, x, residual,
        [&] {
            double change = 0.0;
            for (Eigen::Index i = 0; i < n; ++i)
                change = std::max(change, gauss_seidel_row(i, F.row(i), d, c, x));
            return change;
        },
        [&] { return relative_residual(F, d, c, x, y, o.threads); });
}

// Progressive refinement as Southwell iteration: r = c + D F x − x is the unshot quantity;
// shooting patch i adds δ = r_i / (1 − d_i F_ii) to x_i, clears r_i and sends d_j F_ji δ to
// every other r_j. Column i of F (F_ji, "what j receives from i") is read directly rather than
// through reciprocity (F_ij A_i / A_j), so the fixed point is exactly that of the other solvers
// even for a matrix that breaks reciprocity.
long long run_shooting(const DenseMatrix& F, const std::vector<double>& areas, const Columns& d,
                       const Columns& c, const SolverOptions& o, long long max_it,
                       Progress& progress, Columns& x, Columns& r, Columns& y, double& residual) {
    const Eigen::Index n = F.rows();
    const Eigen::Index kc = x.cols();
    x.setZero();
    r = c;
    long long it = 0;
    // Columns of a row-major F are strided: a transposed copy makes each shot one contiguous
    // pass, at the cost of N² doubles (skipped above kShootingTransposeMax patches).
    const bool transposed = n <= kShootingTransposeMax;
    DenseMatrix Ft;
    if (transposed) Ft = F.transpose();
    auto recompute_residual = [&] {
        multiply(F, x, y, o.threads);
        r = c + (d.array() * y.array()).matrix() - x;
    };
    const CancellationFlag& cancel = current_cancellation();
    while (true) {
        cancel.throw_if_requested();
        // One scan: the shooter, ‖r‖_∞ and ‖x‖_∞.
        Eigen::Index best = -1;
        double best_power = -1.0, rmax = 0.0, xmax = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) {
            double p = 0.0;
            for (Eigen::Index k = 0; k < kc; ++k) {
                const double a = std::abs(r(i, k));
                p += a;
                rmax = std::max(rmax, a);
                xmax = std::max(xmax, std::abs(x(i, k)));
            }
            p *= areas[static_cast<std::size_t>(i)];
            if (p > best_power) {
                best_power = p;
                best = i;
            }
        }
        if (rmax <= o.residual * xmax || rmax == 0.0) {
            // The running residual accumulates rounding: confirm from scratch.
            residual = relative_residual(F, d, c, x, y, o.threads);
            if (residual <= o.residual) return it;
            recompute_residual();
            continue;
        }
        if (it >= max_it) break;
        const Eigen::Index i = best;
        const double fii = F(i, i);
        for (Eigen::Index k = 0; k < kc; ++k) {
            const double delta = r(i, k) / (1.0 - d(i, k) * fii);
            x(i, k) += delta;
            r(i, k) = 0.0;
            if (delta == 0.0) continue;
            if (transposed) {
                const double* col = Ft.data() + i * n;  // row i of Fᵀ = column i of F
                for (Eigen::Index j = 0; j < n; ++j)
                    if (j != i) r(j, k) += d(j, k) * col[j] * delta;
            } else {
                for (Eigen::Index j = 0; j < n; ++j)
                    if (j != i) r(j, k) += d(j, k) * F(j, i) * delta;
            }
        }
        ++it;
        progress.advance();
    }
    residual = relative_residual(F, d, c, x, y, o.threads);
    return it;
}

}  // namespace

std::shared_ptr<const Eigen::PartialPivLU<DenseMatrix>> interruptible_lu(DenseMatrix M) {
    using LU = Eigen::PartialPivLU<DenseMatrix>;
    auto task = std::make_shared<std::packaged_task<std::shared_ptr<const LU>()>>(
        [M = std::move(M)] { return std::make_shared<const LU>(M); });
    std::future<std::shared_ptr<const LU>> done = task->get_future();
    std::thread([task] { (*task)(); }).detach();
    const CancellationFlag& cancel = current_cancellation();
    while (done.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready)
        cancel.throw_if_requested();
    return done.get();
}

namespace {

void run_direct(const DenseMatrix& F, const Columns& d, const Columns& c, Columns& x) {
    const Eigen::Index n = F.rows();
    for (Eigen::Index k = 0; k < c.cols(); ++k) {
        // Channels with the same d share one factorisation.
        Eigen::Index same = -1;
        for (Eigen::Index p = 0; p < k; ++p)
            if (d.col(p) == d.col(k)) {
                same = p;
                break;
            }
        if (same >= 0) continue;
        DenseMatrix M = -(d.col(k).asDiagonal() * F);
        M.diagonal().array() += 1.0;
        const auto factors = interruptible_lu(std::move(M));
        const Eigen::PartialPivLU<DenseMatrix>& lu = *factors;
        const double rcond = lu.rcond();
        if (!(rcond > 1e-14))
            throw Error(fmt::format(
                "solve: the system I - diag(d) F is singular (reciprocal condition number {:.3g})",
                rcond));
        for (Eigen::Index q = k; q < c.cols(); ++q)
            if (q == k || d.col(q) == d.col(k)) x.col(q) = lu.solve(c.col(q));
    }
    if (!x.allFinite()) throw Error("solve: the direct solve produced non-finite values");
    (void)n;
}

constexpr int kGmresRestart = 30;

// The message of a solve that stopped at its iteration limit (st filled but for warnings).
std::string not_converged(const SolverStats& st, const char* unit, const char* advice) {
    return fmt::format(
        "solve: {} did not converge in {} {}: relative residual {:.3g} > tolerance {:.3g} ({})",
        st.solver, st.iterations, unit, st.residual, st.tolerance, advice);
}

// The end of an iterative solve on products or CSR sweeps: residual, convergence, time, and the
// not-converged error (or warning when the options allow it).
void finish_iterative(SolverStats& st, double residual, const SolverOptions& options,
                      std::chrono::steady_clock::time_point start, const char* unit) {
    st.residual = residual;
    st.converged = residual <= options.residual;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (st.converged) return;
    const std::string msg = not_converged(st, unit, "raise `max_iterations` or loosen `residual`");
    if (options.fail_if_not_converged) throw Error(msg);
    st.warnings.push_back(msg);
}

// The stopping rule's options (both solve_linear and solve_linear_operator).
void check_options(const SolverOptions& options) {
    if (!(options.residual > 0.0) || !std::isfinite(options.residual))
        throw OptionError("residual", "must be a positive number");
    if (options.max_iterations < 0)
        throw OptionError("max_iterations", "must be ≥ 0 (0 = automatic)");
}

double operator_residual(const ApplyF& apply, const Columns& d, const Columns& c, const Columns& x,
                         Columns& work) {
    apply(x, work);
    return residual_of(d, c, x, work);
}

// Restarted GMRES on (I − diag(dk) F) x = ck, one column: Arnoldi with modified Gram–Schmidt,
// Givens rotations for the least-squares problem. Stops when the 2-norm of the residual (which
// bounds its ∞-norm) is below tol·‖x‖_∞, confirmed by a residual from scratch at each restart;
// returns the products with F used.
long long gmres_column(const ApplyF& apply, const Columns& dk, const Columns& ck, double tol,
                       long long max_products, Progress& progress, Columns& x) {
    const Eigen::Index n = ck.rows();
    const int m = kGmresRestart;
    Columns V(n, m + 1), w(n, 1), Fx(n, 1);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m + 1, m);
    Eigen::VectorXd g(m + 1), cs(m), sn(m);
    auto apply_a = [&](const Columns& v, Columns& out) {  // out = v − d ∘ (F v)
        apply(v, Fx);
        out = v - (dk.array() * Fx.array()).matrix();
        progress.advance();
    };
    long long products = 0;
    const CancellationFlag& cancel = current_cancellation();
    while (true) {
        cancel.throw_if_requested();
        apply_a(x, w);
        ++products;
        const Columns r = ck - w;
        const double xm = max_abs(x);
        const double rinf = max_abs(r);
        if (rinf <= tol * xm || rinf == 0.0 || products >= max_products) return products;
        const double beta = r.norm();
        V.col(0) = r / beta;
        g.setZero();
        g(0) = beta;
        H.setZero();
        int used = 0;
        for (int j = 0; j < m && products < max_products; ++j) {
            cancel.throw_if_requested();
            apply_a(V.col(j), w);
            ++products;
            for (int i = 0; i <= j; ++i) {
                H(i, j) = w.col(0).dot(V.col(i));
                w.col(0) -= H(i, j) * V.col(i);
            }
            H(j + 1, j) = w.norm();
            if (H(j + 1, j) > 0.0) V.col(j + 1) = w / H(j + 1, j);
            for (int i = 0; i < j; ++i) {
                const double t = cs(i) * H(i, j) + sn(i) * H(i + 1, j);
                H(i + 1, j) = -sn(i) * H(i, j) + cs(i) * H(i + 1, j);
                H(i, j) = t;
            }
            const double den = std::hypot(H(j, j), H(j + 1, j));
            cs(j) = den > 0.0 ? H(j, j) / den : 1.0;
            sn(j) = den > 0.0 ? H(j + 1, j) / den : 0.0;
            H(j, j) = den;
            H(j + 1, j) = 0.0;
            g(j + 1) = -sn(j) * g(j);
            g(j) = cs(j) * g(j);
            used = j + 1;
            if (std::abs(g(j + 1)) <= 0.5 * tol * xm || den == 0.0) break;
        }
        if (used == 0) return products;
        const Eigen::VectorXd y =
            H.topLeftCorner(used, used).triangularView<Eigen::Upper>().solve(g.head(used));
        x.col(0) += V.leftCols(used) * y;
    }
}

// The stats of a solve before it starts: the solver's name and the residual it aims for.
SolverStats initial_stats(const SolverOptions& options) {
    SolverStats st;
    st.solver = to_string(options.solver);
    st.tolerance = options.residual;
    return st;
}

// The phase a solve reports to options.progress: its units are sweeps, shots or products up
// to the limit, and it ends at done = total however early it converges (the count a solve
// will need is not known in advance).
std::string progress_label(const SolverOptions& options) {
    return "solve (" + to_string(options.solver) + ")";
}

// options.max_iterations, or the solver's default when it is 0.
long long max_iterations(const SolverOptions& options, long long fallback) {
    return options.max_iterations > 0 ? options.max_iterations : fallback;
}

}  // namespace

SolverStats solve_linear_operator(const ApplyF& apply, Eigen::Index n, const Columns& d,
                                  const Columns& c, const SolverOptions& options, Columns& x) {
    const auto start = std::chrono::steady_clock::now();
    announce_phase("solve");
    FF_ASSERT(d.rows() == n && c.rows() == n && d.cols() == c.cols());
    check_options(options);
    if (options.solver != SolverKind::jacobi && options.solver != SolverKind::gmres)
        throw OptionError("solver", fmt::format("{} needs the entries of F; an operator that is "
                                                "never formed is solved by gmres or jacobi",
                                                to_string(options.solver)));
    SolverStats st = initial_stats(options);
    x = c;
    Columns y(n, c.cols());
    double residual = 0.0;
    if (options.solver == SolverKind::jacobi) {
        const long long max_it = max_iterations(options, 10000);
        Progress progress(progress_label(options), static_cast<std::size_t>(max_it),
                          options.progress);
        st.iterations = run_jacobi(apply, d, c, options, max_it, progress, x, y, residual);
        progress.finish();
    } else {
        const long long max_it = max_iterations(options, 1000);
        Progress progress(progress_label(options),
                          static_cast<std::size_t>(max_it) * static_cast<std::size_t>(c.cols()),
                          options.progress);
        for (Eigen::Index k = 0; k < c.cols(); ++k) {
            // Channels with the same system and right-hand side share the solution.
            Eigen::Index same = -1;
            for (Eigen::Index p = 0; p < k && same < 0; ++p)
                if (d.col(p) == d.col(k) && c.col(p) == c.col(k)) same = p;
            if (same >= 0) {
                x.col(k) = x.col(same);
                continue;
            }
            Columns xk = x.col(k);
            // The tolerance of one channel relative to the largest solution of all of them
            // would need that solution first: each channel to its own ∞-norm is stricter.
            st.iterations +=
                gmres_column(apply, d.col(k), c.col(k), options.residual, max_it, progress, xk);
            x.col(k) = xk;
        }
        progress.finish();
        residual = operator_residual(apply, d, c, x, y);
    }
    finish_iterative(st, residual, options, start,
                     options.solver == SolverKind::gmres ? "products" : "sweeps");
    return st;
}

SolverStats solve_linear(const DenseMatrix& F, const std::vector<double>& areas, const Columns& d,
                         const Columns& c, const SolverOptions& options, Columns& x) {
    const auto start = std::chrono::steady_clock::now();
    announce_phase("solve");
    const Eigen::Index n = F.rows();
    FF_ASSERT(F.cols() == n && d.rows() == n && c.rows() == n && d.cols() == c.cols());
    FF_ASSERT(static_cast<Eigen::Index>(areas.size()) == n);
    check_options(options);

    if (options.solver == SolverKind::gmres)
        return solve_linear_operator(
            [&](const Columns& v, Columns& out) { multiply(F, v, out, options.threads); }, n, d, c,
            options, x);
    SolverStats st = initial_stats(options);
    x = c;
    Columns y(n, c.cols());
    double residual = 0.0;
    switch (options.solver) {
        case SolverKind::jacobi:
        case SolverKind::gauss_seidel: {
            const long long max_it = max_iterations(options, 10000);
            Progress progress(progress_label(options), static_cast<std::size_t>(max_it),
                              options.progress);
            st.iterations =
                options.solver == SolverKind::jacobi
                    ? run_jacobi([&](const Columns& v,
                                     Columns& out) { multiply(F, v, out, options.threads); },
                                 d, c, options, max_it, progress, x, y, residual)
                    : run_gauss_seidel(F, d, c, options, max_it, progress, x, y, residual);
            progress.finish();
            break;
        }
        case SolverKind::shooting: {
            const long long max_it = options.max_iterations > 0
                                         ? options.max_iterations
                                         : 10000LL * std::max<long long>(1, n);
            Columns r(n, c.cols());
            Progress progress(progress_label(options), static_cast<std::size_t>(max_it),
                              options.progress);
            st.iterations =
                run_shooting(F, areas, d, c, options, max_it, progress, x, r, y, residual);
            progress.finish();
            // Ambient term (Cohen et al. 1988, eq. 5): the unshot power spread evenly, times
            // the interreflection factor 1 / (1 − ρ_avg).
            double total_area = 0.0;
            for (double a : areas) total_area += a;
            st.ambient.assign(static_cast<std::size_t>(c.cols()), 0.0);
            if (total_area > 0.0) {
                for (Eigen::Index k = 0; k < c.cols(); ++k) {
                    double unshot = 0.0, rho = 0.0;
                    for (Eigen::Index i = 0; i < n; ++i) {
                        unshot += areas[static_cast<std::size_t>(i)] * r(i, k);
                        rho += areas[static_cast<std::size_t>(i)] * d(i, k);
                    }
                    unshot /= total_area;
                    rho /= total_area;
                    const double amb = rho < 1.0 ? unshot / (1.0 - rho) : 0.0;
                    st.ambient[static_cast<std::size_t>(k)] = amb;
                    if (options.add_ambient)
                        for (Eigen::Index i = 0; i < n; ++i) x(i, k) += d(i, k) * amb;
                }
            }
            if (options.add_ambient) residual = relative_residual(F, d, c, x, y, options.threads);
            break;
        }
        case SolverKind::gmres:  // above
            break;
        case SolverKind::direct: {
            Progress progress(progress_label(options), 1, options.progress);
            run_direct(F, d, c, x);
            progress.finish();
            st.iterations = 1;
            residual = relative_residual(F, d, c, x, y, options.threads);
            break;
        }
    }
    st.residual = residual;
    st.converged = residual <= options.residual;
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!st.converged) {
        std::string msg;
        if (options.solver == SolverKind::direct)
            msg = fmt::format(
                "solve: the direct solve's relative residual {:.3g} is above the tolerance {:.3g} "
                "(ill-conditioned system)",
                residual, options.residual);
        else
            msg = not_converged(st, options.solver == SolverKind::shooting ? "shots" : "sweeps",
                                "raise `max_iterations`, loosen `residual` or use `solver` direct");
        if (options.fail_if_not_converged && options.solver != SolverKind::direct &&
            !options.add_ambient)
            throw Error(msg);
        st.warnings.push_back(msg);
    }
    return st;
}

void check_sizes(const FormFactors& ff, std::size_t properties) {
    const std::size_t n = ff.size();
    if (static_cast<std::size_t>(ff.F.cols()) != n)
        throw Error(
            fmt::format("solve: the matrix is {}x{}, not square", ff.F.rows(), ff.F.cols()));
    if (ff.areas.size() != n)
        throw Error(fmt::format("solve: {} patch areas for a {}x{} matrix", ff.areas.size(), n, n));
    if (properties != n)
        throw Error(
            fmt::format("solve: the scene has {} patches but the matrix is {}x{} (same scene and "
                        "subdivision?)",
                        properties, n, n));
}

void multiply(const SparseFormFactors& F, const Columns& x, Columns& y, int threads) {
    const auto n = static_cast<Eigen::Index>(F.n);
    const Eigen::Index k = x.cols();
    FF_ASSERT(x.rows() == n);
    if (y.rows() != n || y.cols() != k) y.resize(n, k);
    constexpr Eigen::Index kSparseRowBlock = 256;
    const std::size_t blocks =
        static_cast<std::size_t>((n + kSparseRowBlock - 1) / kSparseRowBlock);
    auto body = [&](std::size_t b) {
        const Eigen::Index lo = static_cast<Eigen::Index>(b) * kSparseRowBlock;
        const Eigen::Index hi = std::min(n, lo + kSparseRowBlock);
        for (Eigen::Index i = lo; i < hi; ++i) {
            const auto begin = static_cast<std::size_t>(F.indptr[static_cast<std::size_t>(i)]);
            const auto end = static_cast<std::size_t>(F.indptr[static_cast<std::size_t>(i) + 1]);
            for (Eigen::Index c = 0; c < k; ++c) {
                double s = 0.0;
                for (std::size_t e = begin; e < end; ++e) s += F.values[e] * x(F.indices[e], c);
                y(i, c) = s;
            }
        }
    };
    if (F.nonzeros() < 4096) {
        for (std::size_t b = 0; b < blocks; ++b) body(b);
    } else {
        parallel_for(blocks, threads, body);
    }
}

namespace {

// Gauss–Seidel sweeps over the stored entries of row i, the diagonal (F_ii, stored when
// non-zero) solved for as in the dense sweep.
long long run_gauss_seidel(const SparseFormFactors& F, const Columns& d, const Columns& c,
                           const SolverOptions& o, long long max_it, Progress& progress, Columns& x,
                           Columns& y, double& residual) {
    const auto n = static_cast<Eigen::Index>(F.n);
    return iterate(
        o, max_it, progress, x, residual,
        [&] {
            double change = 0.0;
            for (Eigen::Index i = 0; i < n; ++i) {
                const auto begin = static_cast<std::size_t>(F.indptr[static_cast<std::size_t>(i)]);
                const auto end =
                    static_cast<std::size_t>(F.indptr[static_cast<std::size_t>(i) + 1]);
                change = std::max(
                    change, gauss_seidel_row(i, F.indices.data() + begin, F.values.data() + begin,
                                             end - begin, d, c, x));
            }
            return change;
        },
        [&] {
            multiply(F, x, y, o.threads);
            return residual_of(d, c, x, y);
        });
}

}  // namespace

void check_sparse_solver(SolverKind kind) {
    if (kind == SolverKind::direct || kind == SolverKind::shooting)
        throw OptionError("solver",
                          fmt::format("{} needs the dense F ({}); a sparse F is solved by "
                                      "gauss-seidel, gmres or jacobi",
                                      to_string(kind),
                                      kind == SolverKind::direct ? "an LU of the N x N system"
                                                                 : "the columns of F"));
}

SolverStats solve_linear(const SparseFormFactors& F, const Columns& d, const Columns& c,
                         const SolverOptions& options, Columns& x) {
    const auto start = std::chrono::steady_clock::now();
    announce_phase("solve");
    const auto n = static_cast<Eigen::Index>(F.n);
    FF_ASSERT(d.rows() == n && c.rows() == n && d.cols() == c.cols());
    check_options(options);
    if (options.solver == SolverKind::gmres || options.solver == SolverKind::jacobi)
        return solve_linear_operator(
            [&](const Columns& v, Columns& out) { multiply(F, v, out, options.threads); }, n, d, c,
            options, x);
    check_sparse_solver(options.solver);
    SolverStats st = initial_stats(options);
    x = c;
    Columns y(n, c.cols());
    double residual = 0.0;
    const long long max_it = max_iterations(options, 10000);
    Progress progress(progress_label(options), static_cast<std::size_t>(max_it), options.progress);
    st.iterations = run_gauss_seidel(F, d, c, options, max_it, progress, x, y, residual);
    progress.finish();
    finish_iterative(st, residual, options, start, "sweeps");
    return st;
}

double max_dropped(const SparseFormFactors& F) {
    double dropped = 0.0;
    for (double v : F.dropped) dropped = std::max(dropped, v);
    return dropped;
}

std::string dropped_mass_warning(const SparseFormFactors& F) {
    const double dropped = max_dropped(F);
    if (!(dropped > 1e-9)) return {};
    return fmt::format(
        "the stored entries of a row carry up to {:.3g} less than the method computed (dropped "
        "mass: what a threshold dropped or an open-scene repair lowered): the solve treats it as "
        "seen by the environment; in a closed scene `repair` closure or both puts it back",
        dropped);
}

void check_sizes(const SparseFormFactors& F, std::size_t properties) {
    if (F.indptr.size() != F.n + 1 || F.areas.size() != F.n)
        throw Error(fmt::format("solve: a sparse matrix of {} rows with {} offsets and {} areas",
                                F.n, F.indptr.size(), F.areas.size()));
    if (properties != F.n)
        throw Error(
            fmt::format("solve: the scene has {} patches but the matrix is {}x{} (same scene and "
                        "subdivision?)",
                        properties, F.n, F.n));
}

}  // namespace detail

std::vector<std::string> solver_dense_matrices(SolverKind kind, std::size_t n) {
    switch (kind) {
        case SolverKind::direct:
            return {"direct solve: system matrix", "direct solve: LU factors"};
        case SolverKind::shooting:
            if (n <= static_cast<std::size_t>(detail::kShootingTransposeMax))
                return {"shooting: F transposed"};
            return {};
        default:
            return {};
    }
}

std::vector<std::string> exchange_factor_dense_matrices() {
    return {"exchange factors: system matrix", "exchange factors: LU factors",
            "exchange factors: result"};
}

}  // namespace formfactor
