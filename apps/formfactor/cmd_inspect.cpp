// `formfactor inspect SCENE --patch I --method hemicube|hemiplane [--point X Y Z]
//  [--resolution R] [--rotation A] [--weights | --delta-map] [--scale S] -o VIEW.png`

#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/output/view_image.h"
#include "formfactor/pipeline.h"

namespace formfactor::cli {

namespace {

struct InspectArgs {
    SceneArgs scene;
    long long patch = -1;
    std::string method = "hemicube";
    std::vector<double> point;
    int resolution = 0;  // 0: 256 for the hemicube, 512 for the hemiplane
    double rotation = 0.0;
    bool weights = false;
    bool delta_map = false;
    int scale = 0;  // 0: enough to make the image at least 512 pixels wide
    std::string output;
};

void run_inspect(const InspectArgs& args) {
    Stopwatch total;
    args.scene.validate();
    if (args.weights && args.delta_map) {
        throw OptionError("--delta-map", "shows the delta form factors alone: drop --weights");
    }
    if (args.scale < 0 || args.scale > 16) {
        throw OptionError("--scale", fmt::format("must be from 1 to 16, got {}", args.scale));
    }
    ViewOptions options;
    options.method = parse_method(args.method);
    options.patch = args.patch;
    if (!args.point.empty()) options.point = Vec3(args.point[0], args.point[1], args.point[2]);
    options.resolution = args.resolution;
    options.rotation_degrees = args.rotation;
    validate(options);
    require_extension(args.output, ".png", "-o");
    check_output_directory(args.output);

    StepTimes times;
    const Scene scene = prepare_scene(args.scene, times);
    Stopwatch sw;
    const PatchView seen = patch_view(scene, options);
    const ProjectionView& view = seen.view;
    times.add("project", sw.lap());
    const int scale = args.scale > 0 ? args.scale : std::max(1, 512 / view.width);
    const Image image =
        args.delta_map ? render_delta_map(view, scale) : render_view(view, args.weights, scale);
    write_png(args.output, image);
    times.add("write", sw.lap());

    const Vec3& x = seen.point;
    const Vec3& n = seen.normal;
    fmt::print("point      ({:.6g}, {:.6g}, {:.6g}) on patch {}, normal ({:.6g}, {:.6g}, {:.6g})\n",
               x.x(), x.y(), x.z(), args.patch, n.x(), n.y(), n.z());
    fmt::print("method     {}, resolution {}, rotation {} degrees\n", args.method, seen.resolution,
               args.rotation);
    if (options.method == MethodKind::hemiplane)
        fmt::print("neglected  {:.6g} (beyond the plane's rim)\n", view.neglected);
    fmt::print("sees       ");
    for (std::size_t k = 0; k < std::min<std::size_t>(seen.seen.size(), 6); ++k) {
        const int item = seen.seen[k].item;
        const std::string what = item >= 0               ? fmt::format("patch {}", item)
                                 : item == kViewNothing  ? std::string("nothing")
                                 : item == kViewBackFace ? std::string("back faces")
                                                         : std::string("obstructions");
        fmt::print("{}{} {:.4f}", k ? ", " : "", what, seen.seen[k].form_factor);
    }
    fmt::print("{}\n", seen.seen.size() > 6 ? ", ..." : "");
    fmt::print("image      {} x {} pixels ({})\n", image.width, image.height,
               args.delta_map ? "delta form factors" : (args.weights ? "weighted" : "items"));
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    fmt::print("wrote      {}\n", args.output);
}

}  // namespace

void add_inspect_command(CLI::App& app) {
    auto args = std::make_shared<InspectArgs>();
    CLI::App* cmd = app.add_subcommand(
        "inspect",
        "Picture of what a point of a patch sees through the hemicube (an unfolded cross) or "
        "the hemiplane (a square): each cell coloured by the patch it sees");
    args->scene.add_to(cmd);
    cmd->add_option("--patch", args->patch, "The patch whose point looks (its normal is used)")
        ->required()
        ->type_name("I");
    cmd->add_option("--method", args->method, "hemicube (default) or hemiplane")->type_name("M");
    cmd->add_option("--point", args->point, "The point (default: the patch's centroid)")
        ->expected(3)
        ->type_name("X Y Z");
    cmd->add_option("--resolution", args->resolution,
                    "Cells per side (default 256 hemicube, 512 hemiplane)")
        ->type_name("R");
    cmd->add_option("--rotation", args->rotation, "Turn about the normal, degrees (default 0)")
        ->type_name("DEG");
    cmd->add_flag("--weights", args->weights, "Darken each cell by its delta form factor");
    cmd->add_flag("--delta-map", args->delta_map, "Show the delta form factors alone");
    cmd->add_option("--scale", args->scale, "Pixels per cell (default: image ≥ 512 wide)")
        ->type_name("S");
    cmd->add_option("-o,--output", args->output, "PNG file")->required()->type_name("VIEW.png");
    cmd->callback([args] { run_inspect(*args); });
}

}  // namespace formfactor::cli
