// `formfactor compute SCENE -o OUT [--report REPORT.json] [--patches PATCHES.csv]
//  [--stderr SE] [--per-surface | --per-patch]`

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/report.h"
#include "solve_common.h"

namespace formfactor::cli {

namespace {

struct ComputeArgs {
    SceneArgs scene;
    MethodArgs method;
    std::string output;
    std::string report;
    std::string patches;
    std::string standard_error;
    bool per_surface = false;  ///< --per-surface
    bool per_patch = false;    ///< --per-patch
    RepairArgs repair;
};

// Rows of -o (and --stderr): per surface when asked, or by default for View3D (.vs3) input,
// whose users expect View3D's own output (one row per surface, subsurfaces separated from their
// base, cmb surfaces combined).
bool rows_per_surface(const ComputeArgs& args) {
    if (args.per_surface || args.per_patch) return args.per_surface;
    std::string ext = std::filesystem::path(args.scene.scene).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext == ".vs3";
}

void run_compute(const ComputeArgs& args) {
    Stopwatch total;
    // Every option and output path is checked before any work.
    args.scene.validate();
    args.method.validate();
    parse_repair_mode(args.repair.mode);
    if (args.output.empty()) {
        throw OptionError("-o", "an output file is required (.csv, .npy or .txt)");
    }
    matrix_format_for(args.output, "-o");
    check_output_directory(args.output);
    if (!args.report.empty()) {
        check_output_directory(args.report);
        if (same_file(args.report, args.output)) {
            throw OptionError("--report", "is the same file as -o");
        }
    }
    if (!args.patches.empty()) {
        require_extension(args.patches, ".csv", "--patches");
        check_output_directory(args.patches);
        if (same_file(args.patches, args.output) ||
            (!args.report.empty() && same_file(args.patches, args.report))) {
            throw OptionError("--patches", "is the same file as another output");
        }
    }

    if (!args.standard_error.empty()) {
        matrix_format_for(args.standard_error, "--stderr");
        check_output_directory(args.standard_error);
        for (const std::string* other : {&args.output, &args.report, &args.patches}) {
            if (!other->empty() && same_file(args.standard_error, *other)) {
                throw OptionError("--stderr", "is the same file as another output");
            }
        }
    }

    StepTimes times;
    Scene scene = prepare_scene(args.scene, times, [&](const Scene& loaded) {
        // The memory a dense run needs, checked before the patches and F exist.
        DenseRunNeeds needs;
        needs.standard_errors =
            method_traits(args.method.resolved_kind(loaded), args.method.method_options(), &loaded)
                .standard_errors;
        needs.repair = parse_repair_mode(args.repair.mode) != RepairMode::none;
        return needs;
    });
    warn_single_patch(scene);
    const MethodKind method = args.method.resolved_kind(scene);
    const MethodTraits traits = method_traits(method, args.method.method_options(), &scene);

    ComputedMatrix computed = compute_matrix(scene, args.method, args.repair, times);
    FormFactors& ff = computed.ff;
    const nlohmann::json& details = computed.details;
    const std::optional<RepairReport>& repaired = computed.repaired;
    Stopwatch sw;

    // What -o and --stderr hold: the patch matrix, or the per-surface one (rows = surfaces).
    const bool per_surface = rows_per_surface(args);
    PatchGroups groups;
    FormFactors per_surface_ff;
    std::vector<double> emissivities = patch_emissivities(scene);
    if (per_surface) {
        groups = surface_groups(scene);
        per_surface_ff = aggregate(ff, groups);
        emissivities.clear();
        for (const auto& members : groups.surfaces)
            emissivities.push_back(
                scene.material_of_surface(static_cast<std::size_t>(members.front())).emissivity);
        times.add("aggregate", sw.lap());
    }
    const FormFactors& written = per_surface ? per_surface_ff : ff;

    OutputTransaction tx;
    MatrixFileInfo info;
    info.areas = written.areas;
    info.emissivities = emissivities;
    info.enclosure = scene.enclosure;
    // F and its standard errors go out in the same formats (-o and --stderr).
    auto stage_matrix = [&](const std::string& path, const DenseMatrix& m) {
        tx.stage(path,
                 [&](std::ostream& out) { write_matrix(out, matrix_format_for(path), m, info); });
    };
    stage_matrix(args.output, written.F);
    if (!args.standard_error.empty()) {
        if (!written.standard_error) {
            throw OptionError("--stderr", "method '" + to_string(method) +
                                              "' gives no standard errors (it is exact; "
                                              "the Monte-Carlo methods give them)");
        }
        stage_matrix(args.standard_error, *written.standard_error);
    }
    if (!args.patches.empty()) {
        tx.stage(args.patches, [&](std::ostream& out) { write_patch_table(out, scene); });
    }
    times.add("write", sw.lap());

    const int threads = effective_threads(args.method.options.threads);
    const Diagnostics d = diagnose(ff);
    if (!args.report.empty()) {
        ReportContext ctx = report_context("compute", to_string(method), args.scene, times, total,
                                           threads, details, traits.reciprocity);
        ctx.options.update(args.method.to_json(to_string(method)));
        ctx.options["output"] = args.output;
        ctx.options["report"] = args.report;
        ctx.options["patches"] =
            args.patches.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.patches);
        ctx.outputs["matrix"] = args.output;
        if (!args.patches.empty()) ctx.outputs["patches"] = args.patches;
        if (!args.standard_error.empty()) ctx.outputs["standard_error"] = args.standard_error;
        ctx.options["standard_error"] = args.standard_error.empty()
                                            ? nlohmann::json(nullptr)
                                            : nlohmann::json(args.standard_error);
        ctx.options["per_surface"] = per_surface;
        ctx.outputs["report"] = args.report;
        ctx.options["repair"] = args.repair.mode;
        nlohmann::json report = make_report(scene, ff, ctx);
        if (repaired) report["repair"] = to_json(*repaired);
        if (per_surface) {
            // The report describes the patch computation; this block the matrix in -o.
            nlohmann::json rows = nlohmann::json::array();
            for (std::size_t g = 0; g < groups.size(); ++g) {
                nlohmann::json members = nlohmann::json::array();
                for (int m : groups.surfaces[g]) members.push_back(m);
                rows.push_back({{"name", groups.names[g]},
                                {"area", per_surface_ff.areas[g]},
                                {"surfaces", members}});
            }
            report["per_surface"] = {
                {"N", per_surface_ff.size()},
                {"rows", rows},
                {"diagnostics", diagnostics_json(diagnose(per_surface_ff), traits.reciprocity)}};
        }
        stage_report(tx, args.report, report);
    }
    tx.commit();

    print_matrix_summary(scene, to_string(method), threads, ff, d, traits.reciprocity, times,
                         total.seconds());
    if (per_surface) {
        const Diagnostics ds = diagnose(per_surface_ff);
        fmt::print(
            "per surface {} rows (surfaces, subsurfaces cut out, cmb combined); row sums "
            "min {:.10g}, max {:.10g}\n",
            per_surface_ff.size(), ds.row_sum_min, ds.row_sum_max);
    }
    std::string wrote = fmt::format("{} ({}×{}{})", args.output, written.F.rows(), written.F.cols(),
                                    per_surface ? ", per surface" : "");
    if (!args.standard_error.empty()) wrote += ", " + args.standard_error;
    if (!args.patches.empty()) wrote += ", " + args.patches;
    if (!args.report.empty()) wrote += ", " + args.report;
    fmt::print("wrote      {}\n", wrote);
}

}  // namespace

void add_compute_command(CLI::App& app) {
    auto args = std::make_shared<ComputeArgs>();
    CLI::App* cmd = app.add_subcommand(
        "compute",
        "Compute the form-factor matrix F of a scene (F_ij from patch i to patch j, row i = "
        "patch i) and write it to a .csv, .npy or .txt (View3D 3.2) file");
    args->scene.add_to(cmd);
    args->method.add_to(cmd);
    args->repair.add_to(cmd);
    cmd->add_option("-o,--output", args->output,
                    "Matrix file: .csv (N×N, %.17g), .npy (float64) or .txt (View3D 3.2 text)")
        ->type_name("OUT");
    cmd->add_option("--report", args->report,
                    "Also write a JSON report (options, timings, diagnostics)")
        ->type_name("REPORT.json");
    cmd->add_option("--patches", args->patches,
                    "Also write the patch table (index, surface, area, centroid, normal) as CSV")
        ->type_name("PATCHES.csv");
    cmd->add_option("--stderr,--standard-error", args->standard_error,
                    "Also write the standard error of each entry (same formats as -o; "
                    "Monte-Carlo methods only)")
        ->type_name("SE");
    auto* ps = cmd->add_flag(
        "--per-surface", args->per_surface,
        "Write one row per surface (View3D's output): A_G F_GH = sum of A_i F_ij over the "
        "patches of G and H, VS3 cmb surfaces merged into their target (default for .vs3 input)");
    auto* pp = cmd->add_flag("--per-patch", args->per_patch,
                             "Write one row per patch (default for built-in scenes and .obj)");
    ps->excludes(pp);
    cmd->callback([args] { run_compute(*args); });
}

}  // namespace formfactor::cli
