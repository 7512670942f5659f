#include "solve_common.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/output/report.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/output/vtu.h"
#include "formfactor/pipeline.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/scene/closure.h"

namespace formfactor::cli {

void RepairArgs::add_to(CLI::App* cmd) {
    cmd->add_option("--repair", mode,
                    "Repair F before use: none, reciprocity (symmetrise A_i "
                    "F_ij), closure or "
                    "both (also scale rows to sum to 1, keeping reciprocity; "
                    "closed scenes only)")
        ->type_name("MODE")
        ->capture_default_str();
    cmd->add_flag("--force-closure", force_closure,
                  "Close the rows even when the scene looks open (row sums < 0.99)");
}

RepairOptions RepairArgs::options(const Scene& scene) const {
    RepairOptions o;
    o.mode = parse_repair_mode(mode);
    o.enclosure = known_enclosure(scene);
    o.force_closure = force_closure;
    return o;
}

namespace {

void print_repair(const RepairReport& r) {
    fmt::print(
        "repair     {}: row sums [{:.10g}, {:.10g}] -> [{:.10g}, {:.10g}], "
        "reciprocity defect "
        "{:.3g} -> {:.3g}, entries moved by at most {:.3g} ({:.3g} relative)\n",
        to_string(r.mode), r.before.row_sum_min, r.before.row_sum_max, r.after.row_sum_min,
        r.after.row_sum_max, r.before.max_reciprocity_defect, r.after.max_reciprocity_defect,
        r.max_abs_change, r.max_relative_change);
    print_warnings(r.warnings);
}

}  // namespace

namespace {

ComputedMatrix computed_matrix(ComputeResult&& r, StepTimes& times) {
    times.add(r.timings);
    ComputedMatrix out;
    out.ff = std::move(r.form_factors);
    out.details = to_json(to_fields(r.report));
    print_method_warnings(r.report);
    out.raw = *r.diagnostics;
    out.repaired = std::move(r.repair);
    if (out.repaired) print_repair(*out.repaired);
    return out;
}

// "a / b / c" of per-rank values.
std::string per_rank(const std::vector<double>& v, const char* format) {
    std::string s;
    for (std::size_t r = 0; r < v.size(); ++r)
        s += (r ? " / " : "") + fmt::format(fmt::runtime(format), v[r]);
    return s;
}

}  // namespace

void print_rank_shares(int threads) {
    const distributed::RankShares& shares = distributed::last_rank_shares();
    if (distributed::size() <= 1 || shares.rows.empty()) return;
    const std::string rows = per_rank(shares.rows, "{:.0f}");
    const std::string busy = per_rank(shares.busy_seconds, "{:.2f}");
    std::string pairs = per_rank(shares.pairs, "{:.0f}");
    if (!pairs.empty())
        pairs = fmt::format("; partly hidden pairs {} in {} parts", pairs, shares.pair_blocks);
    fmt::print("ranks      {} × {} thread{}: rows {}, busy {} s, imbalance {:.1f} %, {} blocks{}\n",
               shares.rows.size(), threads, threads == 1 ? "" : "s", rows, busy,
               100.0 * shares.imbalance(), shares.blocks, pairs);
}

ComputedMatrix compute_matrix(const Scene& scene, const MethodArgs& method,
                              const RepairArgs& repair, StepTimes& times) {
    ComputeOptions o = method.compute_options();
    o.repair = repair.options(scene);
    TerminalProgress bar(cli_text);
    o.progress = &bar;
    o.cancel = &process_cancellation();
    // Over every MPI rank under mpirun; the pipeline's own on one process.
    ComputedMatrix computed = computed_matrix(distributed::compute_form_factors(scene, o), times);
    print_rank_shares(effective_threads(o.method_options.threads));
    return computed;
}

ComputedMatrix use_matrix(const Scene& scene, DenseMatrix F, const std::string& source,
                          const RepairArgs& repair, StepTimes& times) {
    ComputedMatrix out = computed_matrix(
        form_factors_from_matrix(scene, std::move(F), repair.options(scene), source), times);
    out.details = nlohmann::json::object();
    return out;
}

void SolverArgs::add_to(CLI::App* cmd) {
    cmd->add_option("--solver", solver,
                    "jacobi, gauss-seidel, shooting (progressive refinement), "
                    "direct (LU) or gmres; "
                    "default gauss-seidel (radiosity), direct (--thermal), gmres "
                    "(--storage hierarchical)")
        ->type_name("NAME");
    cmd->add_option("--residual", residual, "Stop when max|E + rho F B - B| / max|B| is below this")
        ->type_name("R")
        ->capture_default_str();
    cmd->add_option("--max-iterations", max_iterations,
                    "Sweeps (jacobi, gauss-seidel), shots (shooting) or products "
                    "(gmres); 0 = 10000 sweeps, 10000 N shots or 1000 products")
        ->type_name("K")
        ->capture_default_str();
    cmd->add_flag("--allow-unconverged", allow_unconverged,
                  "Write the current estimate with a warning when the limit is "
                  "reached (default: "
                  "an error)");
}

SolverOptions SolverArgs::options(Storage storage, bool thermal, int threads) const {
    SolverOptions o;
    o.solver = solver.empty() ? default_solver(storage, thermal) : parse_solver(solver);
    if (!(residual > 0.0) || !std::isfinite(residual))
        throw OptionError("--residual", "must be a positive number");
    if (max_iterations < 0) throw OptionError("--max-iterations", "must be >= 0");
    o.residual = residual;
    o.max_iterations = max_iterations;
    o.fail_if_not_converged = !allow_unconverged;
    o.threads = threads;
    return o;
}

namespace {

HierarchicalOptions hierarchical_options(double error_target, int threads) {
    if (!(error_target > 0.0 && error_target <= 0.1))
        throw OptionError("--error-target", "must be in (0, 0.1]");
    HierarchicalOptions ho;
    ho.tolerance = error_target;
    ho.threads = threads;
    return ho;
}

void print_operator_line(const HierarchicalStats& hs) {
    fmt::print(
        "operator   hierarchical, error target {:g}: {} low-rank blocks (rank mean {:.1f}, max "
        "{}), {} dense, {} zero; {} ({:.2f}% of dense F)\n",
        hs.tolerance, hs.low_rank_blocks, hs.mean_rank, hs.max_rank, hs.dense_blocks,
        hs.zero_blocks, format_bytes(static_cast<double>(hs.bytes)),
        100.0 * static_cast<double>(hs.bytes) /
            (8.0 * static_cast<double>(hs.patches) * static_cast<double>(hs.patches)));
}

HierarchicalFormFactors hierarchical_operator(const Scene& scene, double error_target, int threads,
                                              StepTimes& times) {
    HierarchicalOptions ho = hierarchical_options(error_target, threads);
    TerminalProgress bar(cli_text);
    ho.progress = &bar;
    HierarchicalFormFactors H = compute_hierarchical_operator(scene, ho, &times);
    print_operator_line(H.stats());
    return H;
}

distributed::DistributedHierarchical build_hierarchical_on_ranks(const Scene& scene,
                                                                 double error_target, int threads,
                                                                 StepTimes& times) {
    HierarchicalOptions ho = hierarchical_options(error_target, threads);
    Stopwatch sw;
    TerminalProgress bar(cli_text);
    ho.progress = &bar;
    distributed::DistributedHierarchical H = distributed::build_hierarchical(scene, ho);
    times.add("hierarchical operator", sw.lap());
    print_operator_line(H.stats);
    std::vector<double> estimated_mb;
    for (double bytes : H.estimated_bytes) estimated_mb.push_back(bytes / 1e6);
    fmt::print(
        "ranks      {} × {} thread{}: partition {} s; blocks computed {}, busy {} s, imbalance "
        "{:.1f} %; held {} blocks in {} chunks ({} MB moved); memory estimate {} MB\n",
        H.build_seconds.size(), threads, threads == 1 ? "" : "s",
        per_rank(H.partition_seconds, "{:.2f}"), per_rank(H.blocks_built, "{:.0f}"),
        per_rank(H.build_seconds, "{:.2f}"), 100.0 * H.build_imbalance(),
        per_rank(H.blocks_held, "{:.0f}"), per_rank(H.chunks_held, "{:.0f}"),
        fmt::format("{:.1f}", H.moved_bytes / 1e6), per_rank(estimated_mb, "{:.0f}"));
    return H;
}

}  // namespace

HeldOperator held_operator(const Scene& scene, double error_target, int threads, StepTimes& times) {
    HeldOperator held;
    if (distributed::size() > 1)
        held.spread = build_hierarchical_on_ranks(scene, error_target, threads, times);
    else
        held.whole.emplace(hierarchical_operator(scene, error_target, threads, times));
    return held;
}

nlohmann::json to_json(const distributed::DistributedHierarchical& H) {
    return {{"ranks", H.build_seconds.size()},
            {"blocks_computed_per_rank", H.blocks_built},
            {"busy_seconds_per_rank", H.build_seconds},
            {"imbalance", H.build_imbalance()},
            {"blocks_held_per_rank", H.blocks_held},
            {"chunks_held_per_rank", H.chunks_held},
            {"product_work_per_rank", H.product_work},
            {"moved_bytes", H.moved_bytes},
            {"estimated_bytes_per_rank", H.estimated_bytes}};
}

nlohmann::json to_json(const HierarchicalStats& hs) {
    return {{"tolerance", hs.tolerance},
            {"eta", hs.eta},
            {"leaf_size", hs.leaf_size},
            {"clusters", hs.clusters},
            {"leaves", hs.leaves},
            {"zero_blocks", hs.zero_blocks},
            {"dense_blocks", hs.dense_blocks},
            {"low_rank_blocks", hs.low_rank_blocks},
            {"low_rank_fallbacks", hs.low_rank_fallbacks},
            {"dense_values", hs.dense_values},
            {"low_rank_values", hs.low_rank_values},
            {"mean_rank", hs.mean_rank},
            {"max_rank", hs.max_rank},
            {"pairs_zero", hs.pairs_zero},
            {"pairs_dense", hs.pairs_dense},
            {"pairs_low_rank", hs.pairs_low_rank},
            {"entries_computed", hs.entries_computed},
            {"bytes", hs.bytes},
            {"seconds", hs.seconds}};
}

namespace {

// Σ_j F_ij of each row, for the .vtu output of F that is not dense (a dense F has its own
// fields).
std::vector<double> row_sums_of(const SparseFormFactors& F) {
    std::vector<double> sums(F.n);
    for (std::size_t i = 0; i < F.n; ++i) sums[i] = F.row_sum(i);
    return sums;
}
std::vector<double> row_sums_of(const HierarchicalFormFactors& F) { return F.row_sums(); }
std::vector<double> row_sums_of(const distributed::DistributedRows& F) { return F.row_sums; }
std::vector<double> row_sums_of(const distributed::DistributedHierarchical& F) {
    return F.row_sums;
}

// The .vtu fields of F: those of form_factor_fields() for a dense F (with the standard errors
// when it has them), the areas and row sums otherwise.
std::vector<VtuField> matrix_fields(const FormFactors& F) { return form_factor_fields(F); }
template <class Matrix>
std::vector<VtuField> matrix_fields(const Matrix& F) {
    std::vector<double> areas;
    if constexpr (std::is_same_v<Matrix, HierarchicalFormFactors>) {
        areas = F.areas();
    } else {
        areas = F.areas;
    }
    return row_sum_fields(areas, row_sums_of(F));
}

}  // namespace

template <class Matrix>
nlohmann::json solve_and_stage(const Matrix& F, const PatchProperties& props,
                               const SolveOptions& options, const std::string& output,
                               StepTimes& times, Stopwatch& sw, OutputTransaction& tx,
                               const Scene& scene) {
    // The pipeline's solve, or over the MPI ranks for rows kept on them (distributed::solve).
    const SolveResult r = solve(scene, F, props, options);
    times.add(r.timings);
    sw.lap();
    nlohmann::json out;
    const bool vtu = has_extension(output, ".vtu");
    std::vector<VtuField> fields;
    if (vtu) fields = matrix_fields(F);
    if (r.thermal) {
        print_thermal_summary(*r.thermal);
        out = to_json(*r.thermal);
        if (vtu) append_solution_fields(fields, *r.thermal);
    } else {
        print_radiosity_summary(*r.radiosity);
        out = to_json(*r.radiosity);
        if (vtu) append_solution_fields(fields, *r.radiosity);
    }
    if (vtu) {
        tx.stage(output, [&](std::ostream& o) { write_vtu(o, scene, fields); });
    } else {
        const std::string text =
            r.thermal ? thermal_csv_text(*r.thermal) : radiosity_csv_text(r.radiosity->radiosity);
        tx.stage(output, [text](std::ostream& o) { o << text; });
    }
    return out;
}

template nlohmann::json solve_and_stage<FormFactors>(const FormFactors&, const PatchProperties&,
                                                     const SolveOptions&, const std::string&,
                                                     StepTimes&, Stopwatch&, OutputTransaction&,
                                                     const Scene&);
template nlohmann::json solve_and_stage<HierarchicalFormFactors>(
    const HierarchicalFormFactors&, const PatchProperties&, const SolveOptions&, const std::string&,
    StepTimes&, Stopwatch&, OutputTransaction&, const Scene&);
template nlohmann::json solve_and_stage<distributed::DistributedRows>(
    const distributed::DistributedRows&, const PatchProperties&, const SolveOptions&,
    const std::string&, StepTimes&, Stopwatch&, OutputTransaction&, const Scene&);
template nlohmann::json solve_and_stage<distributed::DistributedHierarchical>(
    const distributed::DistributedHierarchical&, const PatchProperties&, const SolveOptions&,
    const std::string&, StepTimes&, Stopwatch&, OutputTransaction&, const Scene&);
template nlohmann::json solve_and_stage<SparseFormFactors>(const SparseFormFactors&,
                                                           const PatchProperties&,
                                                           const SolveOptions&, const std::string&,
                                                           StepTimes&, Stopwatch&,
                                                           OutputTransaction&, const Scene&);

std::vector<bool> emitting_patches(const Scene& scene) {
    std::vector<bool> e(scene.patches.size(), false);
    for (std::size_t i = 0; i < e.size(); ++i)
        e[i] = scene.material_of(i).emission.maxCoeff() > 0.0;
    return e;
}

void print_method_warnings(const MethodReport& report) {
    if (report.details.contains("closed_model_warning"))
        print_warnings({report.details.at("closed_model_warning").text()});
}

void print_warnings(const std::vector<std::string>& warnings) {
    std::fflush(stdout);
    for (const auto& w : warnings) fmt::print(stderr, "formfactor: warning: {}\n", cli_text(w));
}

namespace {

// "solve      <problem>, <solver>: <count> <unit>, residual ... (tolerance ...), ... s".
void print_solve_line(const char* problem, const SolverStats& s) {
    fmt::print(
        "solve      {}, {}: {} {}, residual {:.3g} (tolerance "
        "{:.3g}), {:.3f} s\n",
        problem, s.solver, s.iterations,
        s.solver == "shooting" ? "shots"
        : s.solver == "direct" ? "LU"
        : s.solver == "gmres"  ? "products"
                               : "sweeps",
        s.residual, s.tolerance, s.seconds);
}

}  // namespace

void print_radiosity_summary(const RadiosityResult& r) {
    print_solve_line("radiosity", r.stats);
    const auto& b = r.balance;
    fmt::print(
        "balance    emitted ({:.6g}, {:.6g}, {:.6g}) = absorbed ({:.6g}, "
        "{:.6g}, {:.6g}) + "
        "escaped ({:.6g}, {:.6g}, {:.6g}); relative defect {:.3g}\n",
        b.emitted[0], b.emitted[1], b.emitted[2], b.absorbed[0], b.absorbed[1], b.absorbed[2],
        b.escaped[0], b.escaped[1], b.escaped[2], b.relative_defect);
    print_warnings(r.stats.warnings);
}

void print_thermal_summary(const ThermalResult& r) {
    print_solve_line("thermal", r.stats);
    fmt::print(
        "balance    sum of net power {:.6g} W, to the environment ({} K) "
        "{:.6g} W; relative "
        "defect {:.3g}\n",
        r.total_net_power, r.ambient_temperature, r.escaped_power, r.relative_balance_defect);
    print_warnings(r.warnings);
}

}  // namespace formfactor::cli
