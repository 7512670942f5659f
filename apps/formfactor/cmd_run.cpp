// `formfactor run [SCENE]`: the main job. Computes the form-factor matrix of a scene (by default
// the Cornell box with its blocks), solves radiosity, renders the solution, and writes
// everything into a directory (default out/).

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/page.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/render.h"
#include "formfactor/output/report.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/pipeline_solve.h"
#include "solve_common.h"

namespace formfactor::cli {

namespace {

/// The scene `run` uses without an argument: the Cornell box with its two blocks.
constexpr const char* kRunScene = "cornell";
/// Its default subdivision: 12×12 per surface (2880 patches for the Cornell box), fine enough
/// for soft shadows and colour bleeding.
constexpr int kRunSubdivide = 12;
/// The method for an occluded scene when --method is not given: one set of rays per row gives
/// a whole row of F, so thousands of patches take seconds (default_method's obstruction-aware
/// analytic grows with the partly hidden pairs: ~2.5 min here).
constexpr MethodKind kRunOcclusionMethod = MethodKind::mc_hemisphere;
/// The picture's size in pixels.
constexpr int kRunImageSize = 512;

struct RunArgs {
    SceneArgs scene;
    MethodArgs method;
    SolverArgs solver;
    RepairArgs repair;
    std::string out_dir = "out";
    int image_size = kRunImageSize;
};

void run_run(RunArgs args) {
    Stopwatch total;
    args.scene.validate();
    args.method.validate();
    if (args.image_size < 16 || args.image_size > 16384)
        throw OptionError("--image-size", "must be 16..16384");
    namespace fs = std::filesystem;
    const fs::path dir(args.out_dir);
    if (args.out_dir.empty()) throw OptionError("--out-dir", "must not be empty");
    std::error_code ec;
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
        throw OptionError("--out-dir", "'" + args.out_dir + "' exists and is not a directory");
    }
    const int threads = effective_threads(args.method.options.threads);
    const SolverOptions solver_options = args.solver.options(Storage::dense, false, threads);
    parse_repair_mode(args.repair.mode);

    StepTimes times;
    std::string note;
    Scene scene = prepare_scene(args.scene, times, [&](const Scene& loaded) {
        if (args.method.method.empty() && may_obstruct(loaded)) {
            note = fmt::format(
                "note: {} occludes: run uses {} (a whole row of F per set of rays, seconds for "
                "thousands of patches), not compute's default, the more accurate but slower {}; "
                "choose with --method",
                loaded.name, to_string(kRunOcclusionMethod), to_string(default_method(loaded)));
            args.method.method = to_string(kRunOcclusionMethod);
        }
        // The memory of F, its standard errors, the repair copy and the solver, checked before
        // the patches and F exist.
        DenseRunNeeds needs;
        needs.standard_errors =
            method_traits(args.method.resolved_kind(loaded), args.method.method_options(), &loaded)
                .standard_errors;
        needs.repair = parse_repair_mode(args.repair.mode) != RepairMode::none;
        needs.extra_matrices = solver_dense_matrices(
            solver_options.solver,
            static_cast<std::size_t>(subdivision_patch_count(loaded, args.scene.subdivision())));
        return needs;
    });
    warn_single_patch(scene);
    const MethodKind method = args.method.resolved_kind(scene);
    const MethodTraits traits = method_traits(method, args.method.method_options(), &scene);
    const std::string stem = fs::path(scene.name).stem().string();
    const std::string matrix_npy = (dir / "formfactors.npy").string();
    const std::string patches_csv = (dir / "patches.csv").string();
    const std::string report_json = (dir / "report.json").string();
    const std::string se_npy = (dir / "standard_errors.npy").string();
    const std::string radiosity_csv = (dir / "radiosity.csv").string();
    const std::string image_png = (dir / (stem + ".png")).string();
    const std::string mesh_ply = (dir / (stem + ".ply")).string();
    const std::string page_html_path = (dir / (stem + ".html")).string();
    if (!note.empty()) fmt::print("{}\n", note);
    fmt::print("formfactor run: {} ({} patches), method {}\n", scene.name, scene.patches.size(),
               to_string(method));
    std::fflush(stdout);

    ComputedMatrix computed = compute_matrix(scene, args.method, args.repair, times);
    FormFactors& ff = computed.ff;
    const nlohmann::json& details = computed.details;
    const Diagnostics& raw = computed.raw;
    const std::optional<RepairReport>& repaired = computed.repaired;
    SolveOptions solve_options;
    solve_options.solver = solver_options;
    const SolveResult solved = solve(scene, ff, properties_from_scene(scene), solve_options);
    times.add(solved.timings);
    const RadiosityResult& solution = *solved.radiosity;
    Stopwatch sw;

    RenderOptions ro;
    ro.width = ro.height = args.image_size;
    ro.emitters = emitting_patches(scene);
    RenderInfo info;
    const std::string png = encode_png(render_radiosity(scene, solution.radiosity, ro, &info));
    ExportOptions eo;
    eo.emitters = ro.emitters;
    const std::string ply = encode_mesh(mesh_ply, scene, solution.radiosity, eo);
    times.add("render", sw.lap());

    fs::create_directories(dir, ec);
    if (ec) throw InputError(args.out_dir, 0, "cannot create the directory: " + ec.message());
    OutputTransaction tx;
    tx.stage(matrix_npy, [&](std::ostream& out) { write_npy_matrix(out, ff.F); });
    tx.stage(patches_csv, [&](std::ostream& out) { write_patch_table(out, scene); });
    if (ff.standard_error) {
        tx.stage(se_npy, [&](std::ostream& out) { write_npy_matrix(out, *ff.standard_error); });
    }
    const std::string table = radiosity_csv_text(solution.radiosity);
    tx.stage(radiosity_csv, [&](std::ostream& out) { out << table; });
    tx.stage(image_png, [&](std::ostream& out) { out << png; });
    tx.stage(mesh_ply, [&](std::ostream& out) { out << ply; });
    times.add("write", sw.lap());

    ReportContext ctx = report_context("run", to_string(method), args.scene, times, total, threads,
                                       details, traits.reciprocity);
    ctx.options.update(args.method.to_json(to_string(method)));
    ctx.options["out_dir"] = args.out_dir;
    ctx.options["solver"] = to_string(solver_options.solver);
    ctx.options["residual"] = solver_options.residual;
    ctx.options["repair"] = args.repair.mode;
    ctx.options["image_size"] = args.image_size;
    ctx.outputs = {{"matrix_npy", matrix_npy},   {"patches", patches_csv},
                   {"radiosity", radiosity_csv}, {"image", image_png},
                   {"mesh", mesh_ply},           {"report", report_json}};
    if (ff.standard_error) ctx.outputs["standard_error"] = se_npy;
    ctx.solve = to_json(solution);
    ctx.render = {{"width", args.image_size},
                  {"height", args.image_size},
                  {"exposure", info.exposure},
                  {"triangles", info.triangles}};
    if (repaired) ctx.repair = to_json(*repaired);
    ctx.note = note;
    const nlohmann::json report = make_report(scene, ff, ctx);
    // The result page: the scene, its radiosity in the PNG's exposure, F and this report.
    PageContent page;
    page.form_factors = &ff;
    page.radiosity = solution.radiosity;
    page.exposure = info.exposure;
    page.emitters = ro.emitters;
    page.report = report;
    const std::string page_text = formfactor::page_html(scene, page);
    tx.stage(page_html_path, [&](std::ostream& out) { out << page_text; });
    stage_report(tx, report_json, report);
    tx.commit();

    print_matrix_summary(scene, to_string(method), threads, ff, raw, traits.reciprocity, times,
                         total.seconds());
    print_radiosity_summary(solution);
    fmt::print("wrote      {} ({}×{} float64), {}, {}, {}, {}, {}, {}{}\n", matrix_npy, ff.F.rows(),
               ff.F.cols(), patches_csv, radiosity_csv, image_png, mesh_ply, page_html_path,
               report_json, ff.standard_error ? ", " + se_npy : std::string());
}

}  // namespace

void add_run_command(CLI::App& app) {
    auto args = std::make_shared<RunArgs>();
    CLI::App* cmd = app.add_subcommand(
        "run", fmt::format("The main job: form factors of a scene (default {}, {}×{} patches per "
                           "surface), its radiosity solution and a picture, into a directory: "
                           "formfactors.npy, patches.csv, radiosity.csv, SCENE.png, "
                           "SCENE.ply, SCENE.html (the result page), report.json (and "
                           "standard_errors.npy for a Monte-Carlo method)",
                           kRunScene, kRunSubdivide, kRunSubdivide));
    args->scene.subdivide = kRunSubdivide;
    args->scene.add_to(cmd, kRunScene);
    args->method.add_to(cmd);
    args->solver.add_to(cmd);
    args->repair.add_to(cmd);
    cmd->add_option("--out-dir", args->out_dir, "Directory for the outputs (created)")
        ->capture_default_str()
        ->type_name("DIR");
    cmd->add_option("--image-size", args->image_size, "Width and height of the picture (pixels)")
        ->capture_default_str()
        ->type_name("PX");
    cmd->callback([args] { run_run(*args); });
}

}  // namespace formfactor::cli
