// `formfactor solve SCENE [--matrix F | method options] [--properties P.csv]
// [--thermal]
//  [--solver NAME] [--residual R] [--repair MODE] [--exchange-factors OUT] -o
//  RESULT.csv
//  [--report R.json]`

#include <fmt/format.h>

#include <memory>
#include <optional>

#include "all_zones.h"
#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/distributed/distributed.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/report.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/pipeline_sparse.h"
#include "solve_common.h"
#include "sparse_common.h"

namespace formfactor::cli {

namespace {

struct SolveArgs {
    SceneArgs scene;
    MethodArgs method;
    SolverArgs solver;
    RepairArgs repair;
    std::string matrix;
    std::string properties;
    bool thermal = false;
    double ambient_temperature = 0.0;
    std::string exchange;
    std::string output;
    std::string report;
    std::string storage = "auto";        ///< --storage auto|dense|sparse|hierarchical
    double error_target = 1e-6;          ///< --error-target (hierarchical)
    double threshold = 0.0;              ///< --threshold (sparse)
    bool all_zones = false;              ///< --all-zones (EnergyPlus models)
    OutputTransaction* outer = nullptr;  ///< one zone of --all-zones: its files go there
};

void solve_hierarchical_scene(const SolveArgs& args, Scene& scene, StepTimes& times,
                              Stopwatch& total, const std::string& why);
void solve_sparse_scene(const SolveArgs& args, Scene& scene, StepTimes& times, Stopwatch& total,
                        const std::string& why);
std::string dense_run_is_large(std::size_t n, const DenseRunNeeds& dense);
void solve_distributed_scene(const SolveArgs& args, Scene& scene, StepTimes& times,
                             Stopwatch& total, bool sparse, const SolverOptions& solver_options);

// Whether the solve runs over the MPI ranks, each keeping the rows of F it computed: under
// mpirun, for F computed here without repair (which needs the whole F) or exchange factors
// (an inverse of the whole system), solved by an iterative solver. Otherwise F is gathered on
// rank 0 and solved there.
bool solve_on_ranks(const SolveArgs& args, SolverKind solver) {
    return distributed::size() > 1 && args.matrix.empty() && args.exchange.empty() &&
           parse_repair_mode(args.repair.mode) == RepairMode::none &&
           (solver == SolverKind::jacobi || solver == SolverKind::gauss_seidel ||
            solver == SolverKind::gmres);
}

// Whether `solve --storage auto` takes the hierarchical operator for `loaded` (before
// subdivision; n patches after it), and why; empty when it takes the dense F. Only where the
// operator can do the whole job: the analytic method, no F read or repaired, no exchange
// factors, an iterative solver it supports, a scene without obstructions; and only when the
// dense run would be large: more than 16,384 patches (F alone 2.1 GB, an O(N^3) direct solve)
// or more than half the memory available.
std::string auto_hierarchical(const SolveArgs& args, const Scene& loaded, std::size_t n,
                              const DenseRunNeeds& dense) {
    if (!args.matrix.empty() || !args.exchange.empty()) return {};
    if (parse_repair_mode(args.repair.mode) != RepairMode::none) return {};
    if (args.method.resolved_kind(loaded) != MethodKind::analytic) return {};
    if (!args.solver.solver.empty()) {
        const SolverKind k = parse_solver(args.solver.solver);
        if (k != SolverKind::gmres && k != SolverKind::jacobi) return {};
    }
    const std::string big = dense_run_is_large(n, dense);
    if (big.empty() || !hierarchical_accepts(loaded)) return {};
    return fmt::format("auto: {} patches without obstructions, {}", format_count(double(n)), big);
}

// Why the dense run of n patches is large enough for another storage ("the dense run would need
// 11 GB"), or empty: more than 16,384 patches or more than half the available memory.
std::string dense_run_is_large(std::size_t n, const DenseRunNeeds& dense) {
    DenseRunNeeds needs = dense;
    needs.patches = n;
    const double bytes = estimate_dense_memory(needs).total();
    const double available = available_memory();
    if (!(n > 16384 || (available > 0.0 && bytes > 0.5 * available))) return {};
    return fmt::format("the dense run would need {}", format_bytes(bytes));
}

// Whether `solve --storage auto` takes sparse storage where the hierarchical operator is not
// taken (obstructions, another method, a repair): when the dense run would be large, F is
// neither read nor inverted, and the solver works on CSR. Empty: dense.
std::string auto_sparse(const SolveArgs& args, const Scene& loaded, std::size_t n,
                        const DenseRunNeeds& dense) {
    if (!args.matrix.empty() || !args.exchange.empty()) return {};
    if (!args.solver.solver.empty()) {
        const SolverKind k = parse_solver(args.solver.solver);
        if (k == SolverKind::direct || k == SolverKind::shooting) return {};
    }
    const std::string big = dense_run_is_large(n, dense);
    if (big.empty()) return {};
    const MethodKind method = args.method.resolved_kind(loaded);
    return fmt::format("auto: {} patches, {}; {}", format_count(double(n)), big,
                       method == MethodKind::analytic && !hierarchical_accepts(loaded)
                           ? "obstructions: no hierarchical operator"
                       : method != MethodKind::analytic ? to_string(method) + " rows"
                                                        : "F's entries are needed (--repair)");
}

// The patches' properties: the scene's materials, then --properties; validated.
PatchProperties patch_properties(const SolveArgs& args, const Scene& scene) {
    PatchProperties props = properties_from_scene(scene);
    if (!args.properties.empty()) apply_properties_csv(args.properties, scene, props);
    validate_properties(props);
    return props;
}

// The least, the largest and the mean row sum of F: a report's diagnostics.row_sum where F's
// entries are not at hand.
struct RowSumRange {
    double min = 0.0, max = 0.0, mean = 0.0;
};

RowSumRange row_sum_range(const std::vector<double>& sums) {
    RowSumRange r;
    if (sums.empty()) return r;
    r.min = r.max = sums[0];
    for (double v : sums) {
        r.min = std::min(r.min, v);
        r.max = std::max(r.max, v);
        r.mean += v;
    }
    r.mean /= static_cast<double>(sums.size());
    return r;
}

nlohmann::json row_sum_json(const RowSumRange& r) {
    return {{"min", r.min}, {"max", r.max}, {"mean", r.mean}};
}

// What the pipeline's solve reads: the problem and its solver.
SolveOptions solve_options(const SolveArgs& args, const SolverOptions& solver_options) {
    SolveOptions o;
    o.thermal = args.thermal;
    o.solver = solver_options;
    o.ambient_temperature = args.ambient_temperature;
    return o;
}

// The solve's own options in a report's "options": every path's report has them.
void add_solve_options(const SolveArgs& args, const SolverOptions& solver_options,
                       nlohmann::json& options) {
    options["properties"] =
        args.properties.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.properties);
    options["thermal"] = args.thermal;
    options["solver"] = to_string(solver_options.solver);
    options["residual"] = solver_options.residual;
    options["max_iterations"] = solver_options.max_iterations;
    options["output"] = args.output;
}

// The options of F stored sparse or kept on the ranks (`storage`): the method's (none when F
// was read from `matrix`), the threshold and the repair.
nlohmann::json stored_options(const SolveArgs& args, const std::string& method_name,
                              const std::string& matrix, const std::string& storage) {
    nlohmann::json options =
        matrix.empty() ? args.method.to_json(method_name) : nlohmann::json::object();
    options["matrix"] = matrix.empty() ? nlohmann::json(nullptr) : nlohmann::json(matrix);
    options["storage"] = storage;
    options["threshold"] = args.threshold;
    options["repair"] = args.repair.mode;
    return options;
}

// The report context of a solve on the hierarchical operator, a sparse F or rows kept on the
// ranks (the dense path's comes from report_context()): `options` completed with the solve's
// own, and "solve"; the caller adds its storage's sections.
ReportContext solve_context(const SolveArgs& args, const std::string& method,
                            nlohmann::json options, const SolverOptions& solver_options,
                            int threads, const StepTimes& times, const Stopwatch& total,
                            const nlohmann::json& solve_json) {
    add_solve_options(args, solver_options, options);
    ReportContext ctx;
    ctx.command = "solve";
    ctx.method = method;
    ctx.options = std::move(options);
    ctx.timings = times;
    ctx.total_seconds = total.seconds();
    ctx.threads = threads;
    ctx.outputs = {{"result", args.output}, {"report", args.report}};
    ctx.solve = solve_json;
    return ctx;
}

// `solve --storage hierarchical`: the operator of formfactor/matrix/hierarchical.h, never F.
void run_solve_hierarchical(const SolveArgs& args, Stopwatch& total) {
    if (!args.matrix.empty())
        throw OptionError("--matrix",
                          "reads a dense F; --storage hierarchical computes an operator");
    if (!args.exchange.empty())
        throw OptionError("--exchange-factors",
                          "needs the dense F (an O(N^3) inverse); not with --storage hierarchical");
    if (parse_repair_mode(args.repair.mode) != RepairMode::none)
        throw OptionError("--repair",
                          "needs the entries of F; the hierarchical operator is reciprocal by "
                          "construction (--repair none)");
    if (!(args.error_target > 0.0 && args.error_target <= 0.1))
        throw OptionError("--error-target", "must be in (0, 0.1]");
    const int threads = effective_threads(args.method.options.threads);
    SolverOptions solver_options =
        args.solver.options(Storage::hierarchical, args.thermal, threads);
    if (solver_options.solver != SolverKind::gmres && solver_options.solver != SolverKind::jacobi)
        throw OptionError("--solver",
                          "with --storage hierarchical: gmres (default) or jacobi "
                          "(the others need the entries of F)");
    StepTimes times;
    Scene scene = prepare_scene(args.scene, times);
    solve_hierarchical_scene(args, scene, times, total, "asked for");
}

// The hierarchical solve of a prepared scene (options checked); `why` says why this storage.
void solve_hierarchical_scene(const SolveArgs& args, Scene& scene, StepTimes& times,
                              Stopwatch& total, const std::string& why) {
    const int threads = effective_threads(args.method.options.threads);
    const SolverOptions solver_options =
        args.solver.options(Storage::hierarchical, args.thermal, threads);
    warn_single_patch(scene);
    Stopwatch sw;
    const PatchProperties props = patch_properties(args, scene);

    // Under mpirun the blocks are built and applied over the ranks (the same bits as one
    // process); else the operator is this process's.
    const HeldOperator held = held_operator(scene, args.error_target, threads, times);
    const std::optional<HierarchicalFormFactors>& whole = held.whole;
    const std::optional<distributed::DistributedHierarchical>& spread = held.spread;
    sw.lap();
    const HierarchicalStats& hs = held.stats();
    OutputTransaction tx;
    const SolveOptions problem = solve_options(args, solver_options);
    const nlohmann::json solve_json =
        spread ? solve_and_stage(*spread, props, problem, args.output, times, sw, tx, scene)
               : solve_and_stage(*whole, props, problem, args.output, times, sw, tx, scene);
    times.add("write", sw.lap());
    if (!args.report.empty()) {
        nlohmann::json options = args.method.to_json("analytic");
        options["storage"] = "hierarchical";
        options["error_target"] = args.error_target;
        ReportContext ctx = solve_context(args, "analytic (hierarchical operator)", options,
                                          solver_options, threads, times, total, solve_json);
        ctx.diagnostics = {
            {"row_sum",
             row_sum_json(row_sum_range(spread ? spread->row_sums : whole->row_sums(threads)))},
            {"reciprocity", "exact by construction (one block per unordered cluster pair)"}};
        ctx.details = {{"hierarchical", to_json(hs)}};
        if (spread) ctx.details["mpi"] = to_json(*spread);
        ctx.storage = {{"kind", "hierarchical"}, {"why", why}, {"operator_bytes", hs.bytes}};
        ctx.memory = memory_json();
        stage_report(tx, args.report, make_report(scene, scene.patches.size(), ctx));
    }
    finish(tx, args.outer);
    fmt::print("scene      {}: N = {} patches, hierarchical operator (analytic entries)\n",
               scene.name, scene.patches.size());
    fmt::print("storage    hierarchical ({}), operator {}\n", why, format_bytes(double(hs.bytes)));
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, args.outer);
}

// `solve --storage sparse` (or --matrix F.mtx|F.h5): the checks that need no scene.
void check_sparse_options(const SolveArgs& args) {
    if (!args.matrix.empty() && !is_sparse_matrix_path(args.matrix))
        throw OptionError("--matrix",
                          "with --storage sparse: a sparse F (.mtx or .h5), or no --matrix to "
                          "compute F in CSR form");
    if (!args.matrix.empty() && args.threshold > 0.0)
        throw OptionError("--threshold",
                          "applies when F is computed; the entries of --matrix are used as they "
                          "are");
    if (!args.exchange.empty())
        throw OptionError("--exchange-factors",
                          "needs the dense F (an O(N^3) inverse); not with --storage sparse");
    if (!args.solver.solver.empty()) {
        const SolverKind k = parse_solver(args.solver.solver);
        if (k == SolverKind::direct || k == SolverKind::shooting)
            throw OptionError("--solver",
                              "with --storage sparse: gauss-seidel, gmres or jacobi (direct needs "
                              "the dense system, shooting F's columns)");
    }
}

// The sparse solve of a prepared scene (options checked): F computed in CSR form, or read from
// --matrix F.mtx|F.h5; `why` says why this storage.
void solve_sparse_scene(const SolveArgs& args, Scene& scene, StepTimes& times, Stopwatch& total,
                        const std::string& why) {
    const int threads = effective_threads(args.method.options.threads);
    const SolverOptions solver_options =
        args.solver.options(Storage::sparse, args.thermal, threads);
    if (solve_on_ranks(args, solver_options.solver)) {
        solve_distributed_scene(args, scene, times, total, true, solver_options);
        return;
    }
    warn_single_patch(scene);
    const PatchProperties props = patch_properties(args, scene);
    const bool read = !args.matrix.empty();
    const MethodKind method = args.method.resolved_kind(scene);
    const std::string method_name = read ? "matrix file" : to_string(method);
    SparseComputeResult r;
    if (read) {
        Stopwatch sw;
        SparseFormFactors F = read_sparse_matrix(args.matrix, "--matrix");
        times.add("read matrix", sw.lap());
        r = sparse_form_factors_from_matrix(scene, std::move(F), args.repair.options(scene),
                                            args.matrix);
        times.add(r.timings);
    } else {
        r = compute_sparse_matrix(scene, args.method, args.repair, args.threshold, times);
    }
    const SparseFormFactors& F = r.form_factors;
    Stopwatch sw;
    OutputTransaction tx;
    const nlohmann::json solve_json = solve_and_stage(F, props, solve_options(args, solver_options),
                                                      args.output, times, sw, tx, scene);
    times.add("write", sw.lap());
    if (!args.report.empty()) {
        const nlohmann::json options =
            stored_options(args, to_string(method), read ? args.matrix : "", "sparse");
        ReportContext ctx = solve_context(args, method_name, options, solver_options, threads,
                                          times, total, solve_json);
        add_sparse_sections(r, why, F.threshold, args.repair.mode, ctx);
        ctx.memory["peak_bytes"] = peak_memory_bytes();  // the solve's too
        stage_report(tx, args.report, make_report(scene, scene.patches.size(), ctx));
    }
    finish(tx, args.outer);
    fmt::print("scene      {}: N = {} patches, F from {} ({} thread{})\n", scene.name,
               format_count(double(scene.patches.size())), read ? args.matrix : method_name,
               threads, threads == 1 ? "" : "s");
    print_sparse_summary(scene, r, why, F.threshold, args.repair.mode);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, args.outer);
}

// The solve over the MPI ranks (solve_on_ranks()): F computed with each rank keeping its rows
// (dense, or `sparse` CSR rows above --threshold), the iteration exchanging the solution vector.
void solve_distributed_scene(const SolveArgs& args, Scene& scene, StepTimes& times,
                             Stopwatch& total, bool sparse, const SolverOptions& solver_options) {
    const int threads = effective_threads(args.method.options.threads);
    warn_single_patch(scene);
    const PatchProperties props = patch_properties(args, scene);
    const MethodKind method = args.method.resolved_kind(scene);
    const std::string method_name = to_string(method);
    ComputeOptions o = args.method.compute_options();
    TerminalProgress bar(cli_text);
    o.progress = &bar;
    o.cancel = &process_cancellation();
    SparseOptions so;
    so.threshold = args.threshold;
    const distributed::DistributedRows F =
        distributed::compute_distributed_rows(scene, o, sparse ? &so : nullptr);
    times.add(F.timings);
    print_rank_shares(threads);
    print_method_warnings(F.report);
    Stopwatch sw;
    OutputTransaction tx;
    const nlohmann::json solve_json = solve_and_stage(F, props, solve_options(args, solver_options),
                                                      args.output, times, sw, tx, scene);
    times.add("write", sw.lap());
    const RowSumRange sums = row_sum_range(F.row_sums);
    const std::string kind = sparse ? "sparse" : "dense";
    if (!args.report.empty()) {
        const nlohmann::json options = stored_options(args, method_name, "", kind);
        ReportContext ctx = solve_context(args, method_name, options, solver_options, threads,
                                          times, total, solve_json);
        ctx.diagnostics = {
            {"row_sum", row_sum_json(sums)},
            {"reciprocity", "not checked: the rows of F stay on the ranks that computed them"}};
        ctx.details = to_json(to_fields(F.report));
        ctx.storage = {{"kind", kind},
                       {"why", "rows kept on the MPI ranks that computed them"},
                       {"ranks", distributed::size()},
                       {"rows_per_rank", F.rows_per_rank},
                       {"entries", F.entries},
                       {"threshold", F.threshold}};
        ctx.memory = memory_json();
        stage_report(tx, args.report, make_report(scene, scene.patches.size(), ctx));
    }
    finish(tx, args.outer);
    fmt::print("scene      {}: N = {} patches, F from {} ({} thread{} per rank)\n", scene.name,
               format_count(double(scene.patches.size())), method_name, threads,
               threads == 1 ? "" : "s");
    std::string shares;
    for (std::size_t r = 0; r < F.rows_per_rank.size(); ++r)
        shares += fmt::format("{}{}", r ? " / " : "", format_count(F.rows_per_rank[r]));
    fmt::print(
        "storage    {} rows kept on {} ranks ({} rows, {} entries), solved over the ranks; row "
        "sums [{:.10g}, {:.10g}]\n",
        kind, distributed::size(), shares, format_count(F.entries), sums.min, sums.max);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, args.outer);
}

void run_solve(const SolveArgs& args);

// --all-zones: every zone of an EnergyPlus model solved as its own enclosure. Every output
// (-o, --report, --exchange-factors) and every input (--matrix, --properties) is a file per
// zone, named by zone_file() as compute --all-zones names its outputs; the outputs are written
// together after the last zone, or not at all.
void run_solve_all_zones(const SolveArgs& args) {
    Stopwatch total;
    args.scene.validate();
    args.method.validate();
    const std::vector<std::string> zones = all_zones(args.scene, "solves");
    if (args.output.empty()) throw OptionError("-o", "a result file is required (RESULT.csv)");
    std::vector<SolveArgs> runs;
    ZoneOutputs outputs;
    for (const std::string& zone : zones) {
        SolveArgs one = args;
        one.all_zones = false;
        one.scene.zone = zone;
        for (std::string* path : {&one.output, &one.report, &one.exchange})
            outputs.claim(*path, zone);
        for (std::string* path : {&one.matrix, &one.properties})
            if (!path->empty()) *path = zone_file(*path, zone);
        runs.push_back(std::move(one));
    }
    OutputTransaction tx;
    for (SolveArgs& one : runs) {
        fmt::print("zone       {}\n", one.scene.zone);
        one.outer = &tx;
        run_solve(one);
    }
    const std::vector<std::string> files = tx.paths();
    tx.commit();
    fmt::print("time       all zones {:.3g} s\n", total.seconds());
    fmt::print("wrote      {} files for {} zones\n", files.size(), zones.size());
}

void run_solve(const SolveArgs& args) {
    if (args.all_zones) {
        run_solve_all_zones(args);
        return;
    }
    Stopwatch total;
    args.scene.validate();
    args.method.validate();
    if (args.output.empty()) throw OptionError("-o", "a result file is required (RESULT.csv)");
    if (!has_extension(args.output, ".vtu")) require_extension(args.output, ".csv", "-o");
    check_output_directory(args.output);
    if (!args.report.empty()) {
        check_output_directory(args.report);
        if (same_file(args.report, args.output))
            throw OptionError("--report", "is the same file as -o");
    }
    if (!args.exchange.empty()) {
        matrix_format_for(args.exchange, "--exchange-factors");
        check_output_directory(args.exchange);
        if (same_file(args.exchange, args.output) ||
            (!args.report.empty() && same_file(args.exchange, args.report)))
            throw OptionError("--exchange-factors", "is the same file as another output");
    }
    if (args.storage != "auto" && args.storage != "dense" && args.storage != "sparse" &&
        args.storage != "hierarchical")
        throw OptionError(
            "--storage", "must be auto, dense, sparse or hierarchical, got '" + args.storage + "'");
    if (!(args.threshold >= 0.0) || !std::isfinite(args.threshold))
        throw OptionError("--threshold", "must be a finite number >= 0");
    if (args.threshold > 0.0 && args.storage != "sparse" && args.storage != "auto")
        throw OptionError("--threshold", "applies to sparse storage (--storage sparse)");
    if (args.storage == "auto" && !(args.error_target > 0.0 && args.error_target <= 0.1))
        throw OptionError("--error-target", "must be in (0, 0.1]");
    if (!(args.ambient_temperature >= 0.0) || !std::isfinite(args.ambient_temperature))
        throw OptionError("--ambient-temperature", "must be a temperature >= 0 K");
    if (args.ambient_temperature > 0.0 && !args.thermal)
        throw OptionError("--ambient-temperature", "needs --thermal");
    if (args.storage == "hierarchical") {
        if (!args.solver.solver.empty()) parse_solver(args.solver.solver);
        run_solve_hierarchical(args, total);
        return;
    }
    parse_repair_mode(args.repair.mode);
    // --threshold, or a sparse --matrix file, asks for sparse storage.
    const bool sparse_matrix = !args.matrix.empty() && is_sparse_matrix_path(args.matrix);
    if (sparse_matrix && args.storage != "auto" && args.storage != "sparse")
        throw OptionError("--matrix", "a sparse F (.mtx, .h5) is solved with sparse storage");
    if (args.storage == "sparse" || (args.storage == "auto" && args.threshold > 0.0) ||
        sparse_matrix) {
        check_sparse_options(args);
        StepTimes times;
        Scene scene = prepare_scene(args.scene, times);
        solve_sparse_scene(args, scene, times, total,
                           sparse_matrix              ? "read from " + args.matrix
                           : args.storage == "sparse" ? std::string("asked for")
                                                      : std::string("auto: --threshold given"));
        return;
    }
    if (!args.matrix.empty()) matrix_format_for(args.matrix, "--matrix");
    if (!args.solver.solver.empty()) parse_solver(args.solver.solver);
    const int threads = effective_threads(args.method.options.threads);
    const SolverOptions solver_options = args.solver.options(Storage::dense, args.thermal, threads);

    StepTimes times;
    std::string hierarchical_why;  // set when --storage auto takes the operator
    std::string sparse_why;        // set when --storage auto takes sparse storage
    Scene scene = prepare_scene(args.scene, times, [&](const Scene& loaded) {
        // The memory of F (computed or read), its standard errors, the repair copy, the solver
        // and the exchange factors, checked before the patches and F exist.
        DenseRunNeeds needs;
        if (args.matrix.empty())
            needs.standard_errors = method_traits(args.method.resolved_kind(loaded),
                                                  args.method.method_options(), &loaded)
                                        .standard_errors;
        needs.repair = parse_repair_mode(args.repair.mode) != RepairMode::none;
        const auto n =
            static_cast<std::size_t>(subdivision_patch_count(loaded, args.scene.subdivision()));
        needs.extra_matrices = solver_dense_matrices(solver_options.solver, n);
        if (!args.exchange.empty())
            for (const std::string& m : exchange_factor_dense_matrices())
                needs.extra_matrices.push_back(m);
        if (args.storage == "auto") {
            hierarchical_why = auto_hierarchical(args, loaded, n, needs);
            if (hierarchical_why.empty()) sparse_why = auto_sparse(args, loaded, n, needs);
            if (!hierarchical_why.empty() || !sparse_why.empty()) {
                // The operator and the sparse run check their own memory.
                DenseRunNeeds none;
                none.matrix = false;
                return none;
            }
        }
        return needs;
    });
    if (!hierarchical_why.empty()) {
        solve_hierarchical_scene(args, scene, times, total, hierarchical_why);
        return;
    }
    if (!sparse_why.empty()) {
        solve_sparse_scene(args, scene, times, total, sparse_why);
        return;
    }
    if (solve_on_ranks(args, solver_options.solver)) {
        solve_distributed_scene(args, scene, times, total, false, solver_options);
        return;
    }
    warn_single_patch(scene);
    Stopwatch sw;
    // Properties first: a bad CSV fails before the expensive part.
    const PatchProperties props = patch_properties(args, scene);

    std::string method_name;
    ReciprocityPromise promise;  // unknown for a matrix read from a file
    nlohmann::json details = nlohmann::json::object();
    ComputedMatrix computed;
    if (!args.matrix.empty()) {
        DenseMatrix F = read_matrix(args.matrix, "--matrix");
        times.add("read matrix", sw.lap());
        method_name = "matrix file";
        computed = use_matrix(scene, std::move(F), args.matrix, args.repair, times);
    } else {
        const MethodKind method = args.method.resolved_kind(scene);
        method_name = to_string(method);
        promise = method_traits(method, args.method.method_options(), &scene).reciprocity;
        computed = compute_matrix(scene, args.method, args.repair, times);
        details = std::move(computed.details);
    }
    sw.lap();
    FormFactors& ff = computed.ff;
    const Diagnostics& diagnostics = computed.raw;
    const std::optional<RepairReport>& repaired = computed.repaired;

    OutputTransaction tx;
    const nlohmann::json solve_json = solve_and_stage(
        ff, props, solve_options(args, solver_options), args.output, times, sw, tx, scene);
    if (!args.exchange.empty()) {
        const DenseMatrix X = total_exchange_factors(ff.F, props.emissivity);
        times.add("exchange factors", sw.lap());
        MatrixFileInfo info;
        info.areas = ff.areas;
        info.emissivities = props.emissivity;
        info.enclosure = scene.enclosure;
        info.did_emit = true;
        tx.stage(args.exchange, [&](std::ostream& out) {
            write_matrix(out, matrix_format_for(args.exchange), X, info);
        });
    }
    times.add("write", sw.lap());
    if (!args.report.empty()) {
        ReportContext ctx = report_context("solve", method_name, args.scene, times, total, threads,
                                           details, promise);
        if (args.matrix.empty()) ctx.options.update(args.method.to_json(method_name));
        ctx.options["matrix"] =
            args.matrix.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.matrix);
        add_solve_options(args, solver_options, ctx.options);
        ctx.options["repair"] = args.repair.mode;
        ctx.outputs["result"] = args.output;
        if (!args.exchange.empty()) ctx.outputs["exchange_factors"] = args.exchange;
        ctx.outputs["report"] = args.report;
        ctx.solve = solve_json;
        if (repaired) ctx.repair = to_json(*repaired);
        stage_report(tx, args.report, make_report(scene, ff, ctx));
    }
    finish(tx, args.outer);
    fmt::print("scene      {}: N = {} patches, F from {}\n", scene.name, scene.patches.size(),
               method_name);
    print_reciprocity(diagnostics, promise);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.exchange.empty()) wrote += ", " + args.exchange;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, args.outer);
}

}  // namespace

void add_solve_command(CLI::App& app) {
    auto args = std::make_shared<SolveArgs>();
    CLI::App* cmd =
        app.add_subcommand("solve",
                           "Solve radiosity B = E + rho F B (RGB, from the materials) or, "
                           "with --thermal, the "
                           "grey-body heat exchange (emissivity, temperature or net flux "
                           "per patch); F is computed "
                           "or read with --matrix");
    args->scene.add_to(cmd);
    args->method.add_to(cmd);
    cmd->add_option("--matrix", args->matrix,
                    "Read F (.csv, .npy or .txt; sparse: .mtx or .h5 as compute writes them) "
                    "instead of computing it; rows = the scene's patches after subdivision")
        ->type_name("F.npy");
    cmd->add_option("--properties", args->properties,
                    "Per-patch or per-surface overrides: reflectance_r/g/b, "
                    "emission_r/g/b, "
                    "emissivity, temperature, net_flux (docs/solve.md)")
        ->type_name("P.csv");
    cmd->add_flag("--thermal", args->thermal,
                  "Thermal problem: J = eps sigma T^4 + (1 - eps) F J, net flux per patch");
    cmd->add_option("--ambient-temperature", args->ambient_temperature,
                    "Thermal: temperature (K) of the environment seen through "
                    "the open part "
                    "of each row")
        ->type_name("K")
        ->capture_default_str();
    cmd->add_option("--exchange-factors", args->exchange,
                    "Also write Hottel's total exchange factors script-F (.csv, "
                    ".npy, .txt)")
        ->type_name("OUT");
    args->solver.add_to(cmd);
    args->repair.add_to(cmd);
    cmd->add_option("-o,--output", args->output,
                    "Result table: patch,radiosity_r,radiosity_g,radiosity_b or (thermal) "
                    "patch,area,emissivity,temperature,radiosity,net_flux,net_power; or .vtu: "
                    "the patches with these fields and area, row sum and sky factor (ParaView)")
        ->type_name("RESULT.csv");
    cmd->add_option("--report", args->report, "Also write a JSON report")->type_name("REPORT.json");
    cmd->add_option("--storage", args->storage,
                    "auto (default): hierarchical for more than 16,384 patches (or a dense run "
                    "over half the memory) in a scene without obstructions when nothing needs F's "
                    "entries, sparse when the dense run would be as large but the operator "
                    "does not apply (obstructions, another method, --repair), else dense, and "
                    "says which; dense: F as an N x N matrix; sparse: F in CSR form (rows in "
                    "blocks, docs/sparse.md), solved by gauss-seidel, gmres or jacobi; "
                    "hierarchical: a compressed operator (low-rank far blocks, exact near blocks) "
                    "solved by products, for large scenes without obstructions "
                    "(docs/hierarchical.md)")
        ->type_name("auto|dense|sparse|hierarchical")
        ->capture_default_str();
    cmd->add_option("--threshold", args->threshold,
                    "Sparse storage: drop entries F_ij <= T (the dropped mass per row is kept; "
                    "--repair closure|both puts it back in a closed scene); implies "
                    "--storage sparse under auto")
        ->type_name("T")
        ->capture_default_str();
    cmd->add_option("--error-target", args->error_target,
                    "Hierarchical storage: relative error of each compressed block")
        ->type_name("T")
        ->capture_default_str();
    cmd->add_flag("--all-zones", args->all_zones,
                  "EnergyPlus models: every zone, each its own enclosure and solve; -o, "
                  "--report, --exchange-factors and the inputs --matrix and --properties are a "
                  "file per zone, the zone's name in place of {zone} or before the extension "
                  "(B.csv -> B_ZONE.csv), as compute --all-zones writes them");
    cmd->callback([args] { run_solve(*args); });
}

}  // namespace formfactor::cli
