// `formfactor render SCENE --radiosity RESULT.csv [--camera ...] [--size W H]
// [--flat]
//  [--exposure X] [--false-colour QUANTITY [--row I --matrix F]] -o
//  image.png|.ply|.gltf|.glb`

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/render.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/pipeline.h"
#include "solve_common.h"

namespace formfactor::cli {

namespace {

struct RenderArgs {
    SceneArgs scene;
    std::string radiosity;
    std::vector<double> camera;
    std::vector<int> size = {640, 640};
    bool flat = false;
    double exposure = 0.0;
    int supersample = 2;
    bool back_faces = false;
    std::string false_colour;
    long long row = -1;
    CLI::Option* row_opt = nullptr;
    std::string matrix;
    std::string output;
};

void run_render(const RenderArgs& args) {
    Stopwatch total;
    args.scene.validate();
    if (args.output.empty())
        throw OptionError("-o", "an output file is required (.png, .ply, .gltf or .glb)");
    const bool mesh = is_mesh_path(args.output);
    if (!mesh) require_extension(args.output, ".png", "-o");
    check_output_directory(args.output);
    std::string quantity = args.false_colour;
    if (quantity.empty() && args.row_opt && args.row_opt->count() > 0) quantity = "row";
    if (quantity == "form-factor" || quantity == "form_factor") quantity = "row";
    if (quantity == "net-flux") quantity = "net_flux";
    if (!quantity.empty() && quantity != "temperature" && quantity != "net_flux" &&
        quantity != "radiosity" && quantity != "row")
        throw OptionError("--false-colour", "unknown quantity '" + args.false_colour +
                                                "' (temperature, net_flux, radiosity or row)");
    if (quantity == "row") {
        if (args.matrix.empty()) throw OptionError("--row", "needs --matrix F");
        if (args.row < 0) throw OptionError("--row", "needs a patch index I >= 0");
        matrix_format_for(args.matrix, "--matrix");
    } else if (args.radiosity.empty()) {
        throw OptionError("--radiosity", "a solution table is required (from formfactor solve)");
    }
    if (args.size.size() != 2 || args.size[0] < 1 || args.size[1] < 1 || args.size[0] > 16384 ||
        args.size[1] > 16384)
        throw OptionError("--size", "expects W H, each 1..16384");
    if (!args.camera.empty() && args.camera.size() != 10)
        throw OptionError("--camera", "expects 10 numbers: EX EY EZ TX TY TZ UX UY UZ FOV");
    if (args.exposure < 0.0 || !std::isfinite(args.exposure))
        throw OptionError("--exposure", "must be > 0 (or 0 = automatic)");

    StepTimes times;
    const Scene scene = prepare_scene(args.scene, times);
    Stopwatch sw;
    const std::size_t n = scene.patches.size();
    std::optional<SolutionTable> table;
    if (!args.radiosity.empty()) table = read_solution_csv(args.radiosity, n);

    RenderOptions ro;
    ro.width = args.size[0];
    ro.height = args.size[1];
    ro.flat = args.flat;
    ro.exposure = args.exposure;
    ro.supersample = args.supersample;
    ro.back_faces = args.back_faces;
    ro.emitters = emitting_patches(scene);
    if (!args.camera.empty()) {
        const auto& c = args.camera;
        Camera cam;
        cam.eye = Vec3(c[0], c[1], c[2]);
        cam.target = Vec3(c[3], c[4], c[5]);
        cam.up = Vec3(c[6], c[7], c[8]);
        cam.fov_degrees = c[9];
        ro.camera = cam;
    }

    std::string bytes;
    std::string what;
    if (quantity.empty()) {
        what = table->thermal ? "radiosity J (grey)" : "radiosity";
        if (mesh) {
            ExportOptions eo;
            eo.flat = args.flat;
            eo.exposure = args.exposure;
            eo.emitters = ro.emitters;
            bytes = encode_mesh(args.output, scene, table->radiosity, eo);
        } else {
            RenderInfo info;
            bytes = encode_png(render_radiosity(scene, table->radiosity, ro, &info));
            what += fmt::format(", exposure {:.4g}", info.exposure);
        }
    } else {
        FalseColourField f;
        if (quantity == "row") {
            const DenseMatrix F = form_factors_from_matrix(
                                      scene, read_matrix(args.matrix, "--matrix"), {}, args.matrix)
                                      .form_factors.F;
            if (static_cast<std::size_t>(args.row) >= n)
                throw OptionError("--row",
                                  fmt::format("patch {} out of range (0..{})", args.row, n - 1));
            f.values.assign(F.row(args.row).data(), F.row(args.row).data() + n);
            f.label = fmt::format("F from patch {}", args.row);
        } else if (quantity == "radiosity") {
            for (const Rgb& b : table->radiosity)
                f.values.push_back(0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2]);
            f.label = table->thermal ? "radiosity J" : "radiosity (luminance)";
            f.unit = table->thermal ? "W/m2" : "";
        } else {
            if (!table->thermal)
                throw OptionError("--false-colour",
                                  quantity + " needs a thermal result table (solve --thermal)");
            f.values = quantity == "temperature" ? table->temperature : table->net_flux;
            f.label = quantity == "temperature" ? "temperature" : "net flux";
            f.unit = quantity == "temperature" ? "K" : "W/m2";
        }
        what = "false colour: " + f.label;
        if (mesh) {
            double lo = 0.0, hi = 0.0;
            bytes = encode_false_colour_mesh(args.output, scene, f, args.flat, &lo, &hi);
            what += fmt::format(", range [{:.4g}, {:.4g}]", lo, hi);
        } else {
            RenderInfo info;
            bytes = encode_png(render_false_colour(scene, f, ro, &info));
            what += fmt::format(", range [{:.4g}, {:.4g}]", info.value_min, info.value_max);
        }
    }
    times.add("render", sw.lap());
    write_file_atomically(args.output, [&](std::ostream& out) { out << bytes; });
    times.add("write", sw.lap());
    fmt::print("scene      {}: N = {} patches\n", scene.name, n);
    fmt::print("render     {}{}\n", what,
               mesh ? "" : fmt::format(", {}x{} pixels", args.size[0], args.size[1]));
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    fmt::print("wrote      {}\n", args.output);
}

}  // namespace

void add_render_command(CLI::App& app) {
    auto args = std::make_shared<RenderArgs>();
    CLI::App* cmd =
        app.add_subcommand("render",
                           "Picture of a solution: a PNG seen through the scene's camera "
                           "(or --camera), in "
                           "radiosity colours or false colour, or a 3D mesh with vertex "
                           "colours (.ply, .gltf, .glb)");
    args->scene.add_to(cmd);
    cmd->add_option("--radiosity", args->radiosity,
                    "Solution table from formfactor solve (radiosity or thermal)")
        ->type_name("RESULT.csv");
    cmd->add_option("--camera", args->camera,
                    "Eye, target, up and vertical field of view in degrees")
        ->type_name("EX EY EZ TX TY TZ UX UY UZ FOV")
        ->expected(10);
    cmd->add_option("--size", args->size, "Image width and height in pixels")
        ->type_name("W H")
        ->expected(2)
        ->capture_default_str();
    cmd->add_flag("--flat", args->flat, "One value per patch (no smoothing to the vertices)");
    cmd->add_option("--exposure", args->exposure,
                    "Multiplier of the linear radiosity before sRGB (0 = "
                    "automatic: the 99th "
                    "percentile of the lit surfaces maps to 0.9)")
        ->type_name("X")
        ->capture_default_str();
    cmd->add_option("--supersample", args->supersample, "Samples per pixel per axis (1..8)")
        ->type_name("S")
        ->capture_default_str();
    cmd->add_flag("--back-faces", args->back_faces,
                  "Draw the backs of patches dark grey (default: culled)");
    cmd->add_option("--false-colour,--false-color", args->false_colour,
                    "Heat map of temperature, net_flux, radiosity or row (a row "
                    "of F: --row I "
                    "--matrix F) with a colour bar")
        ->type_name("QUANTITY");
    args->row_opt =
        cmd->add_option("--row", args->row, "Patch I whose row of F to show")->type_name("I");
    cmd->add_option("--matrix", args->matrix, "Form-factor matrix for --row (.csv, .npy, .txt)")
        ->type_name("F");
    cmd->add_option("-o,--output", args->output, "image.png, or a mesh: .ply, .gltf or .glb")
        ->type_name("OUT");
    cmd->callback([args] { run_render(*args); });
}

}  // namespace formfactor::cli
