// `formfactor solve SCENE [--matrix F | method options] [--properties P.csv]
// [--thermal]
//  [--solver NAME] [--residual R] [--repair MODE] [--exchange-factors OUT] -o
//  RESULT.csv
//  [--report R.json]`

#include <fmt/format.h>

#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/report.h"
#include "formfactor/output/solution_io.h"
#include "solve_common.h"

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
};

void run_solve(const SolveArgs& args) {
    Stopwatch total;
    args.scene.validate();
    args.method.validate();
    if (args.output.empty()) throw OptionError("-o", "a result file is required (RESULT.csv)");
    require_extension(args.output, ".csv", "-o");
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
    if (!args.matrix.empty()) matrix_format_for(args.matrix, "--matrix");
    parse_repair_mode(args.repair.mode);
    if (!args.solver.solver.empty()) parse_solver(args.solver.solver);
    if (!(args.ambient_temperature >= 0.0) || !std::isfinite(args.ambient_temperature))
        throw OptionError("--ambient-temperature", "must be a temperature >= 0 K");
    if (args.ambient_temperature > 0.0 && !args.thermal)
        throw OptionError("--ambient-temperature", "needs --thermal");
    const int threads = effective_threads(args.method.options.threads);
    const SolverOptions solver_options =
        args.solver.options(args.thermal ? SolverKind::direct : SolverKind::gauss_seidel, threads);

    StepTimes times;
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
        return needs;
    });
    warn_single_patch(scene);
    Stopwatch sw;
    // Properties first: a bad CSV fails before the expensive part.
    PatchProperties props = properties_from_scene(scene);
    if (!args.properties.empty()) apply_properties_csv(args.properties, scene, props);
    validate_properties(props);

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
    nlohmann::json solve_json;
    if (args.thermal) {
        ThermalOptions to;
        to.solver = solver_options;
        to.ambient_temperature = args.ambient_temperature;
        const ThermalResult r = solve_thermal(ff, props, to);
        times.add("solve", sw.lap());
        print_thermal_summary(r);
        solve_json = to_json(r);
        const std::string text = thermal_csv_text(r);
        tx.stage(args.output, [&](std::ostream& out) { out << text; });
    } else {
        const RadiosityResult r = solve_radiosity(ff, props, solver_options);
        times.add("solve", sw.lap());
        print_radiosity_summary(r);
        solve_json = to_json(r);
        const std::string text = radiosity_csv_text(r.radiosity);
        tx.stage(args.output, [&](std::ostream& out) { out << text; });
    }
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
        ctx.options["properties"] =
            args.properties.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.properties);
        ctx.options["thermal"] = args.thermal;
        ctx.options["solver"] = to_string(solver_options.solver);
        ctx.options["residual"] = solver_options.residual;
        ctx.options["max_iterations"] = solver_options.max_iterations;
        ctx.options["repair"] = args.repair.mode;
        ctx.options["output"] = args.output;
        ctx.outputs["result"] = args.output;
        if (!args.exchange.empty()) ctx.outputs["exchange_factors"] = args.exchange;
        ctx.outputs["report"] = args.report;
        nlohmann::json report = make_report(scene, ff, ctx);
        report["solve"] = solve_json;
        if (repaired) report["repair"] = to_json(*repaired);
        stage_report(tx, args.report, report);
    }
    tx.commit();
    fmt::print("scene      {}: N = {} patches, F from {}\n", scene.name, scene.patches.size(),
               method_name);
    print_reciprocity(diagnostics, promise);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.exchange.empty()) wrote += ", " + args.exchange;
    if (!args.report.empty()) wrote += ", " + args.report;
    fmt::print("wrote      {}\n", wrote);
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
                    "Read F (.csv, .npy or .txt) instead of computing it; rows = "
                    "the scene's "
                    "patches after subdivision")
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
                    "patch,area,emissivity,temperature,radiosity,net_flux,net_power")
        ->type_name("RESULT.csv");
    cmd->add_option("--report", args->report, "Also write a JSON report")->type_name("REPORT.json");
    cmd->callback([args] { run_solve(*args); });
}

}  // namespace formfactor::cli
