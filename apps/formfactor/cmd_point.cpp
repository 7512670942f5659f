// `formfactor point SCENE (--at X Y Z --normal NX NY NZ | --points FILE.csv) [-o OUT]`

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <ostream>
#include <sstream>

#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/points.h"

namespace formfactor::cli {

namespace {

struct PointArgs {
    SceneArgs scene;
    std::vector<double> at;
    std::vector<double> normal;
    std::string points;
    std::string output;
    int threads = 0;
    CLI::Option* at_opt = nullptr;
    CLI::Option* normal_opt = nullptr;
};

// One element: `patch,F`, one line per patch.
void write_row_csv(std::ostream& out, const DenseMatrix& F) {
    out << "patch,F\n";
    for (Eigen::Index j = 0; j < F.cols(); ++j) out << fmt::format("{},{:.17g}\n", j, F(0, j));
}

void run_point(const PointArgs& args) {
    Stopwatch total;
    args.scene.validate();
    const bool single = args.points.empty();
    const bool has_at = args.at_opt->count() > 0, has_normal = args.normal_opt->count() > 0;
    if (!single && (has_at || has_normal))
        throw OptionError(has_at ? "--at" : "--normal",
                          "cannot be combined with --points (one point, or a file of points)");
    if (single && !has_at) throw OptionError("--at", "is required (or --points FILE.csv)");
    if (single && !has_normal) throw OptionError("--normal", "is required with --at");
    MatrixFormat format = MatrixFormat::Csv;
    if (!args.output.empty()) {
        if (single) {
            require_extension(args.output, ".csv", "-o");
        } else {
            format = matrix_format_for(args.output, "-o");
            if (format == MatrixFormat::View3dText)
                throw OptionError("-o",
                                  "use .csv or .npy for a matrix of points (.txt is "
                                  "View3D's square patch matrix)");
        }
        check_output_directory(args.output);
    }

    PointOptions options;
    options.threads = args.threads;
    if (single) {
        const Vec3 x(args.at[0], args.at[1], args.at[2]);
        if (!x.allFinite()) throw OptionError("--at", "coordinates must be finite numbers");
        const Vec3 n(args.normal[0], args.normal[1], args.normal[2]);
        if (!n.allFinite()) throw OptionError("--normal", "components must be finite numbers");
        const double big = n.cwiseAbs().maxCoeff();
        if (!(big > 0.0)) throw OptionError("--normal", "must not be the zero vector");
        options.positions.push_back(x);
        options.normals.push_back((n / big).normalized());
    }
    validate(options);

    StepTimes times;
    Stopwatch sw;
    if (!single) {
        PointElements pts = read_points_csv(args.points);
        options.positions = std::move(pts.positions);
        options.normals = std::move(pts.normals);
        times.add("read points", sw.lap());
    }
    const std::vector<Vec3>& positions = options.positions;
    const std::vector<Vec3>& normals = options.normals;
    const Scene scene = prepare_scene(args.scene, times, [&](const Scene&) {
        DenseRunNeeds needs;
        needs.matrix = false;
        needs.output_rows = positions.size();
        return needs;
    });
    const PointResult result = compute_point_form_factors(scene, options);
    times.add(result.timings);
    sw.lap();
    const DenseMatrix& F = result.F;

    if (args.output.empty()) {
        std::ostringstream text;
        if (single)
            write_row_csv(text, F);
        else
            write_csv_matrix(text, F);
        fmt::print("{}", text.str());
        return;
    }
    write_file_atomically(args.output, [&](std::ostream& out) {
        if (single)
            write_row_csv(out, F);
        else
            write_matrix(out, format, F);
    });
    times.add("write", sw.lap());
    if (single) {
        fmt::print("point      ({}, {}, {}), normal ({:.6g}, {:.6g}, {:.6g})\n", positions[0].x(),
                   positions[0].y(), positions[0].z(), normals[0].x(), normals[0].y(),
                   normals[0].z());
    } else {
        fmt::print("points     {} from {}\n", positions.size(), args.points);
    }
    const std::size_t obstructions = scene.obstruction_count();
    fmt::print("scene      {}: {} patches{}\n", scene.name, scene.patches.size(),
               obstructions ? fmt::format(", {} obstructions", obstructions) : std::string());
    if (single) {
        fmt::print("sum of F   {:.10g}\n", F.sum());
    } else {
        const Eigen::VectorXd sums = F.rowwise().sum();
        fmt::print("sums of F  min {:.10g}, max {:.10g} (per point)\n", sums.minCoeff(),
                   sums.maxCoeff());
    }
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    fmt::print("wrote      {}{}\n", args.output,
               single ? std::string()
                      : fmt::format(" ({}×{}: row = point, column = patch)", F.rows(), F.cols()));
}

}  // namespace

void add_point_command(CLI::App& app) {
    auto args = std::make_shared<PointArgs>();
    CLI::App* cmd = app.add_subcommand(
        "point",
        "Form factors F(dA → patch j) from differential elements (a point with a normal, or a "
        "file of them) to every patch: exact, with obstructions (the blockers' shadows clipped "
        "out of each patch)");
    args->scene.add_to(cmd);
    args->at_opt = cmd->add_option("--at", args->at, "Position of the element")
                       ->expected(3)
                       ->type_name("X Y Z");
    args->normal_opt =
        cmd->add_option("--normal", args->normal, "Front normal of the element (normalised here)")
            ->expected(3)
            ->type_name("NX NY NZ");
    cmd->add_option("--points", args->points,
                    "Many elements: a CSV file, one line x,y,z,nx,ny,nz per point (an optional "
                    "header line, # comments); gives an M×N matrix (row = point, column = patch)")
        ->type_name("FILE.csv");
    cmd->add_option("-o,--output", args->output,
                    "With --at: CSV `patch,F`, one line per patch. With --points: the M×N matrix, "
                    ".csv (no header, %.17g) or .npy (float64). Default: standard output (CSV)")
        ->type_name("OUT");
    cmd->add_option("--threads", args->threads, "Worker threads (0 = all cores)")
        ->type_name("T")
        ->capture_default_str();
    cmd->callback([args] { run_point(*args); });
}

}  // namespace formfactor::cli
