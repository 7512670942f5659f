// `formfactor run [SCENE]`: the main job. Computes the form-factor matrix of a scene (by default
// the empty Cornell box) and writes everything into a directory (default out/).

#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/output/atomic_file.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/report.h"

namespace formfactor::cli {

namespace {

/// The scene `run` uses without an argument: the Cornell box with its two blocks (occlusion, so
/// the default method is a ray-traced one).
constexpr const char* kRunScene = "cornell";
/// Its default subdivision: 3×3 per surface (180 patches), a real but quick job (about 1.5 s of
/// mc-target on 2 cores).
constexpr int kRunSubdivide = 3;

struct RunArgs {
    SceneArgs scene;
    MethodArgs method;
    std::string out_dir = "out";
};

void run_run(const RunArgs& args) {
    Stopwatch total;
    args.scene.validate();
    args.method.validate();
    namespace fs = std::filesystem;
    const fs::path dir(args.out_dir);
    if (args.out_dir.empty()) throw OptionError("--out-dir", "must not be empty");
    std::error_code ec;
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
        throw OptionError("--out-dir", "'" + args.out_dir + "' exists and is not a directory");
    }
    const std::string matrix_npy = (dir / "formfactors.npy").string();
    const std::string matrix_csv = (dir / "formfactors.csv").string();
    const std::string patches_csv = (dir / "patches.csv").string();
    const std::string report_json = (dir / "report.json").string();
    const std::string se_npy = (dir / "standard_errors.npy").string();

    StepTimes times;
    Scene scene = load_and_subdivide(args.scene, times);
    const auto method = args.method.resolve(scene);
    fmt::print("formfactor run: {} ({} patches), method {}\n", scene.name, scene.patches.size(),
               method->name());
    std::fflush(stdout);

    Stopwatch sw;
    MethodOptions options = args.method.method_options();
    options.progress = true;
    nlohmann::json details = nlohmann::json::object();
    const FormFactors ff = method->compute(scene, options, details);
    times.add("compute", sw.lap());

    fs::create_directories(dir, ec);
    if (ec) throw InputError(args.out_dir, 0, "cannot create the directory: " + ec.message());
    OutputTransaction tx;
    tx.stage(matrix_npy, [&](std::ostream& out) { write_npy_matrix(out, ff.F); });
    tx.stage(matrix_csv, [&](std::ostream& out) { write_csv_matrix(out, ff.F); });
    tx.stage(patches_csv, [&](std::ostream& out) { write_patch_table(out, scene); });
    if (ff.standard_error) {
        tx.stage(se_npy, [&](std::ostream& out) { write_npy_matrix(out, *ff.standard_error); });
    }
    times.add("write", sw.lap());

    const int threads = effective_threads(options.threads);
    ReportContext ctx;
    ctx.command = "run";
    ctx.method = method->name();
    ctx.options = args.scene.to_json();
    ctx.options.update(args.method.to_json(method->name()));
    ctx.options["out_dir"] = args.out_dir;
    ctx.timings = times;
    ctx.total_seconds = total.seconds();
    ctx.threads = threads;
    ctx.details = details;
    ctx.outputs = {{"matrix_npy", matrix_npy},
                   {"matrix_csv", matrix_csv},
                   {"patches", patches_csv},
                   {"report", report_json}};
    if (ff.standard_error) ctx.outputs["standard_error"] = se_npy;
    const std::string text = json_text(make_report(scene, ff, ctx));
    tx.stage(report_json, [&](std::ostream& out) {
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
    });
    tx.commit();

    print_matrix_summary(scene, method->name(), threads, ff, diagnose(ff.F, ff.areas), times,
                         total.seconds());
    fmt::print("wrote      {} ({}×{} float64), {}, {}, {}{}\n", matrix_npy, ff.F.rows(),
               ff.F.cols(), matrix_csv, patches_csv, report_json,
               ff.standard_error ? ", " + se_npy : std::string());
}

}  // namespace

void add_run_command(CLI::App& app) {
    auto args = std::make_shared<RunArgs>();
    CLI::App* cmd = app.add_subcommand(
        "run",
        fmt::format("The main job: form factors of a scene (default {}, {}×{} patches per "
                    "surface) into a directory: formfactors.npy, formfactors.csv, patches.csv, "
                    "report.json (and standard_errors.npy for a Monte-Carlo method)",
                    kRunScene, kRunSubdivide, kRunSubdivide));
    args->scene.subdivide = kRunSubdivide;
    args->scene.add_to(cmd, kRunScene);
    args->method.add_to(cmd);
    cmd->add_option("--out-dir", args->out_dir, "Directory for the outputs (created)")
        ->capture_default_str()
        ->type_name("DIR");
    cmd->callback([args] { run_run(*args); });
}

}  // namespace formfactor::cli
