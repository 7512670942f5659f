// `formfactor view SCENE [method options | --matrix F] [--radiosity B.csv | --thermal T.csv]
// -o result.html`: the result page (formfactor/output/page.h), one self-contained HTML file.

#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "all_zones.h"
#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/page.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/solve/properties.h"
#include "solve_common.h"

namespace formfactor::cli {

namespace {

struct ViewArgs {
    SceneArgs scene;
    MethodArgs method;
    RepairArgs repair;
    std::string matrix;
    std::string radiosity;
    std::string thermal;
    bool no_solve = false;
    long long max_entries = static_cast<long long>(PageOptions{}.max_entries);
    double threshold = -1.0;
    std::string title;
    std::string output;
    bool all_zones = false;              ///< --all-zones (EnergyPlus models)
    OutputTransaction* outer = nullptr;  ///< one zone of --all-zones: its page goes there
};

bool emits(const Scene& scene) {
    for (std::size_t i = 0; i < scene.patches.size(); ++i)
        if (scene.material_of(i).emission.maxCoeff() > 0.0) return true;
    return false;
}

void run_view(const ViewArgs& args);

// --all-zones: a page per zone of an EnergyPlus model, each zone its own enclosure; -o and the
// inputs --matrix, --radiosity and --thermal are a file per zone, named by zone_file() as
// compute and solve --all-zones name theirs. The pages are written together after the last zone,
// or not at all.
void run_view_all_zones(const ViewArgs& args) {
    Stopwatch total;
    args.scene.validate();
    const std::vector<std::string> zones = all_zones(args.scene, "makes a page for");
    if (args.output.empty()) throw OptionError("-o", "an output file is required (.html)");
    std::vector<ViewArgs> runs;
    ZoneOutputs outputs;
    for (const std::string& zone : zones) {
        ViewArgs one = args;
        one.all_zones = false;
        one.scene.zone = zone;
        outputs.claim(one.output, zone);
        for (std::string* path : {&one.matrix, &one.radiosity, &one.thermal})
            if (!path->empty()) *path = zone_file(*path, zone);
        runs.push_back(std::move(one));
    }
    OutputTransaction tx;
    for (ViewArgs& one : runs) {
        fmt::print("zone       {}\n", one.scene.zone);
        one.outer = &tx;
        run_view(one);
    }
    const std::vector<std::string> files = tx.paths();
    tx.commit();
    fmt::print("time       all zones {:.3g} s\n", total.seconds());
    fmt::print("wrote      {} files for {} zones\n", files.size(), zones.size());
}

void run_view(const ViewArgs& args) {
    if (args.all_zones) {
        run_view_all_zones(args);
        return;
    }
    Stopwatch total;
    args.scene.validate();
    if (args.output.empty()) throw OptionError("-o", "an output file is required (.html)");
    require_extension(args.output, ".html", "-o");
    check_output_directory(args.output);
    if (!args.radiosity.empty() && !args.thermal.empty())
        throw OptionError("--thermal", "give --radiosity or --thermal, not both");
    if (args.max_entries < 1) throw OptionError("--max-entries", "must be ≥ 1");
    if (!args.matrix.empty()) {
        if (!is_sparse_matrix_path(args.matrix)) matrix_format_for(args.matrix, "--matrix");
    } else {
        args.method.validate();
    }
    const int threads = effective_threads(args.method.options.threads);

    StepTimes times;
    // A dense F that will not fit is refused before the patches and F exist (as compute does).
    Scene scene = prepare_scene(args.scene, times, [&](const Scene& loaded) {
        DenseRunNeeds needs;
        needs.matrix = args.matrix.empty() || !is_sparse_matrix_path(args.matrix);
        if (args.matrix.empty())
            needs.standard_errors = method_traits(args.method.resolved_kind(loaded),
                                                  args.method.method_options(), &loaded)
                                        .standard_errors;
        needs.repair = parse_repair_mode(args.repair.mode) != RepairMode::none;
        return needs;
    });
    warn_single_patch(scene);
    const std::size_t n = scene.patches.size();
    PageContent content;
    content.title = args.title;
    content.emitters = emitting_patches(scene);

    // A solution table is read first, so that a wrong one fails before F is computed.
    const std::string table_path = !args.thermal.empty() ? args.thermal : args.radiosity;
    if (!table_path.empty()) {
        Stopwatch read;
        const SolutionTable table = read_solution_csv(table_path, n);
        if (table.thermal != !args.thermal.empty())
            throw InputError(table_path, 0,
                             table.thermal ? "a thermal table: give it with --thermal"
                                           : "a radiosity table: give it with --radiosity");
        if (table.thermal) {
            content.temperature = table.temperature;
            content.net_flux = table.net_flux;
            for (const Rgb& j : table.radiosity) content.thermal_radiosity.push_back(j[0]);
        } else {
            content.radiosity = table.radiosity;
        }
        times.add("read solution", read.lap());
    }

    // F: computed, or read (dense or sparse).
    ComputedMatrix computed;
    SparseFormFactors sparse;
    std::string method_name = "matrix file";
    ReciprocityPromise promise;
    if (args.matrix.empty()) {
        const MethodKind method = args.method.resolved_kind(scene);
        method_name = to_string(method);
        promise = method_traits(method, args.method.method_options(), &scene).reciprocity;
        fmt::print("formfactor view: {} ({} patches), method {}\n", scene.name, n, method_name);
        std::fflush(stdout);
        computed = compute_matrix(scene, args.method, args.repair, times);
        content.form_factors = &computed.ff;
    } else if (is_sparse_matrix_path(args.matrix)) {
        Stopwatch sw;
        sparse = read_sparse_matrix(args.matrix, "--matrix");
        if (sparse.n != n)
            throw InputError(
                args.matrix, 0,
                fmt::format("F is {}×{} but the scene has {} patches", sparse.n, sparse.n, n));
        times.add("read matrix", sw.lap());
        content.sparse = &sparse;
    } else {
        Stopwatch sw;
        DenseMatrix F = read_matrix(args.matrix, "--matrix");
        times.add("read matrix", sw.lap());
        computed = use_matrix(scene, std::move(F), args.matrix, args.repair, times);
        content.form_factors = &computed.ff;
    }

    // Without a table, radiosity solved on F when the scene has light.
    nlohmann::json solve_json;
    if (table_path.empty() && !args.no_solve && content.form_factors && emits(scene)) {
        SolveOptions so;
        so.solver.solver = default_solver(Storage::dense, so.thermal);
        so.solver.threads = threads;
        const SolveResult solved =
            solve(scene, *content.form_factors, properties_from_scene(scene), so);
        content.radiosity = solved.radiosity->radiosity;
        solve_json = to_json(*solved.radiosity);
        times.add(solved.timings);
    }
    Stopwatch sw;

    ReportContext ctx = report_context(
        "view", method_name, args.scene, times, total, threads,
        computed.details.is_null() ? nlohmann::json::object() : computed.details, promise);
    if (args.matrix.empty()) ctx.options.update(args.method.to_json(method_name));
    ctx.options["matrix"] =
        args.matrix.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.matrix);
    ctx.options["repair"] = args.repair.mode;
    ctx.outputs = {{"page", args.output}};
    ctx.solve = solve_json;
    nlohmann::json report;
    if (content.form_factors) {
        if (computed.repaired) ctx.repair = to_json(*computed.repaired);
        report = make_report(scene, computed.ff, ctx);
    } else {
        ctx.storage = "sparse";
        report = make_report(scene, sparse.n, ctx);
        // The sparse F read from --matrix.
        report["matrix"] = args.matrix;
        report["nonzeros"] = sparse.nonzeros();
        report["threshold"] = sparse.threshold;
    }
    if (!table_path.empty()) report["solution"] = table_path;

    PageOptions po;
    po.max_entries = static_cast<std::size_t>(args.max_entries);
    po.threshold = args.threshold;
    const std::string html = page_html(scene, content, po);
    times.add("page", sw.lap());
    OutputTransaction tx;
    tx.stage(args.output, [&](std::ostream& out) { out << html; });
    finish(tx, args.outer);
    times.add("write", sw.lap());
    if (content.form_factors)
        print_matrix_summary(scene, method_name, threads, computed.ff, computed.raw, promise, times,
                             total.seconds());
    else
        fmt::print("time       {}\n", format_timings(times, total.seconds()));
    print_wrote(fmt::format("{} ({:.1f} MB)", args.output, double(html.size()) / 1e6), args.outer);
}

}  // namespace

void add_view_command(CLI::App& app) {
    auto args = std::make_shared<ViewArgs>();
    CLI::App* cmd = app.add_subcommand(
        "view",
        "The result page: one self-contained HTML file (no network) showing the scene in 3D, "
        "coloured by radiosity, temperature, net flux, row sum, sky factor or standard error; "
        "click a patch for its row of F (docs/page.md)");
    args->scene.add_to(cmd);
    args->method.add_to(cmd);
    args->repair.add_to(cmd);
    cmd->add_option("--matrix", args->matrix,
                    "Read F instead of computing it (.npy, .csv, .txt; sparse .mtx, .h5)")
        ->type_name("F");
    cmd->add_option("--radiosity", args->radiosity, "Radiosity table from formfactor solve")
        ->type_name("B.csv");
    cmd->add_option("--thermal", args->thermal, "Thermal table from formfactor solve --thermal")
        ->type_name("T.csv");
    cmd->add_flag("--no-solve", args->no_solve,
                  "Do not solve radiosity on F (solved by default when the scene emits light)");
    cmd->add_option("--max-entries", args->max_entries,
                    "Entries of F the page stores at most (the smallest entries beyond are "
                    "dropped; the page states the threshold and each row's dropped mass)")
        ->capture_default_str()
        ->type_name("N");
    cmd->add_option("--page-threshold", args->threshold,
                    "Store exactly the entries F_ij > T (instead of --max-entries)")
        ->type_name("T");
    cmd->add_option("--title", args->title, "The page's heading (default: the scene's title)")
        ->type_name("TEXT");
    cmd->add_option("-o,--output", args->output, "result.html")->type_name("OUT");
    cmd->add_flag("--all-zones", args->all_zones,
                  "EnergyPlus models: a page per zone, each zone its own enclosure; -o and the "
                  "inputs --matrix, --radiosity and --thermal are a file per zone, the zone's "
                  "name in place of {zone} or before the extension (page.html -> "
                  "page_ZONE.html), as compute --all-zones writes them");
    cmd->callback([args] { run_view(*args); });
}

}  // namespace formfactor::cli
