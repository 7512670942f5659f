// `formfactor point SCENE --at X Y Z --normal NX NY NZ [-o OUT.csv]`

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <ostream>

#include "commands.h"
#include "common.h"
#include "formfactor/core/error.h"
#include "formfactor/methods/analytic.h"
#include "formfactor/output/atomic_file.h"

namespace formfactor::cli {

namespace {

struct PointArgs {
    SceneArgs scene;
    std::vector<double> at;
    std::vector<double> normal;
    std::string output;
};

void write_point_csv(std::FILE* out, const std::vector<double>& F) {
    fmt::print(out, "patch,F\n");
    for (std::size_t j = 0; j < F.size(); ++j) fmt::print(out, "{},{:.17g}\n", j, F[j]);
}

void run_point(const PointArgs& args) {
    Stopwatch total;
    args.scene.validate();
    const Vec3 x(args.at[0], args.at[1], args.at[2]);
    if (!x.allFinite()) throw OptionError("--at", "coordinates must be finite numbers");
    Vec3 n(args.normal[0], args.normal[1], args.normal[2]);
    if (!n.allFinite()) throw OptionError("--normal", "components must be finite numbers");
    if (!(n.norm() > 0.0)) throw OptionError("--normal", "must not be the zero vector");
    n.normalize();
    if (!args.output.empty()) {
        require_extension(args.output, ".csv", "-o");
        check_output_directory(args.output);
    }

    StepTimes times;
    Scene scene = load_and_subdivide(args.scene, times);
    make_method("analytic")->check(scene);  // the point form is exact only without occlusion

    Stopwatch sw;
    std::vector<double> F(scene.patches.size());
    double sum = 0.0;
    for (std::size_t j = 0; j < F.size(); ++j) {
        F[j] = point_to_polygon(x, n, scene.patches[j].polygon);
        sum += F[j];
    }
    times.add("compute", sw.lap());

    if (args.output.empty()) {
        write_point_csv(stdout, F);
        return;
    }
    write_file_atomically(args.output, [&](std::ostream& out) {
        out << "patch,F\n";
        for (std::size_t j = 0; j < F.size(); ++j) out << fmt::format("{},{:.17g}\n", j, F[j]);
    });
    times.add("write", sw.lap());
    fmt::print("point      ({}, {}, {}), normal ({:.6g}, {:.6g}, {:.6g})\n", x.x(), x.y(), x.z(),
               n.x(), n.y(), n.z());
    fmt::print("scene      {}: {} patches\n", scene.name, scene.patches.size());
    fmt::print("sum of F   {:.10g}\n", sum);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    fmt::print("wrote      {}\n", args.output);
}

}  // namespace

void add_point_command(CLI::App& app) {
    auto args = std::make_shared<PointArgs>();
    CLI::App* cmd = app.add_subcommand(
        "point",
        "Form factors F(dA → patch j) from a differential element at a point to every patch "
        "(exact, Lambert's formula; scenes without occlusion)");
    args->scene.add_to(cmd);
    cmd->add_option("--at", args->at, "Position of the element")
        ->required()
        ->expected(3)
        ->type_name("X Y Z");
    cmd->add_option("--normal", args->normal, "Front normal of the element (normalised here)")
        ->required()
        ->expected(3)
        ->type_name("NX NY NZ");
    cmd->add_option("-o,--output", args->output,
                    "CSV file (`patch,F`, one line per patch); default: standard output")
        ->type_name("OUT.csv");
    cmd->callback([args] { run_point(*args); });
}

}  // namespace formfactor::cli
