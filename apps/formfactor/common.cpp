#include "common.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/random.h"
#include "formfactor/output/report.h"

namespace formfactor::cli {

namespace {

std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
    return out.empty() ? std::string("(none)") : out;
}

}  // namespace

std::string builtin_scene_list() { return join(builtin_scene_names()); }

std::string generator_list() { return join(builtin_scene_generators()); }

std::string help_footer() {
    return "Scenes (SCENE): .obj (with .mtl), .vs3 (View3D 3.2), .idf, .epJSON (EnergyPlus), .msh "
           "(Gmsh), .stl, .ply, .gltf, .glb, .off, or\n"
           "  built-in scenes: " +
           builtin_scene_list() +
           "\n"
           "  generators: " +
           generator_list() +
           " (N = 1, 2, ...)\n"
           "Methods (--method): " +
           join(method_names()) +
           "\n"
           "Matrix formats (-o, --matrix): .csv, .npy, .txt, .dat (dense; the last: Elmer); .mtx, "
           ".h5 (sparse)\n"
           "Other outputs (-o): .vtu (ParaView cells), .idf and .epJSON (EnergyPlus view factors "
           "per\n"
           "  surface); 'formfactor view' writes .html.\n"
           "Run 'formfactor SUBCOMMAND --help' for the options of a subcommand.\n"
           "Exit codes: 0 success, 1 bad input file, 2 bad usage or option, 3 internal error.\n"
           "Licence: MIT. Documentation: README.md and docs/.";
}

void SceneArgs::add_to(CLI::App* cmd, const std::string& default_scene) {
    auto* opt = cmd->add_option(
        "SCENE", scene,
        "A scene file (.obj, .vs3, .idf, .epJSON, .msh, .stl, .ply, .gltf, .glb, .off), or a "
        "built-in scene: " +
            builtin_scene_list() + "; or a generator: " + generator_list() + " (N = 1, 2, ...)");
    if (default_scene.empty()) {
        opt->required();
    } else {
        scene = default_scene;
        opt->capture_default_str();
    }
    subdivide_opt = cmd->add_option("--subdivide", subdivide,
                                    "Split every surface into N×N patches (quads; triangles into "
                                    "N², other polygons alike)");
    subdivide_opt->type_name("N");
    if (subdivide != 1) subdivide_opt->capture_default_str();
    max_edge_opt = cmd->add_option("--max-edge", max_edge,
                                   "Split surfaces until no patch edge is longer than L (scene "
                                   "units); excludes --subdivide");
    max_edge_opt->type_name("L");
    cmd->add_option("--zone", zone,
                    "EnergyPlus models (.idf, .epJSON): the zone whose enclosure is computed "
                    "(needed when the model has several)")
        ->type_name("NAME");
    cmd->add_flag("--merge-coplanar", merge_coplanar,
                  "Merge the coplanar, edge-connected triangles of each surface (an STL or "
                  "glTF mesh, a Gmsh physical group) back into polygons before subdividing");
}

void SceneArgs::validate() const {
    const bool has_n = subdivide_opt && subdivide_opt->count() > 0;
    const bool has_l = max_edge_opt && max_edge_opt->count() > 0;
    if (has_n && has_l) {
        throw OptionError("--subdivide", "cannot be combined with --max-edge (choose one)");
    }
    formfactor::validate(subdivision());  // the library's own checks, fields shown as flags
    if (subdivide > 100000) {
        throw OptionError("--subdivide",
                          fmt::format("{} is too large (at most 100000)", subdivide));
    }
    if (has_l && max_edge == 0.0) {  // the library reads 0 as "no limit"; given, it is a slip
        throw OptionError("--max-edge", "must be a finite length > 0, got 0");
    }
}

SubdivisionOptions SceneArgs::subdivision() const {
    SubdivisionOptions o;
    const bool has_l = max_edge_opt && max_edge_opt->count() > 0;
    if (has_l) {
        o.n = 1;
        o.max_edge = max_edge;
    } else {
        o.n = subdivide;
        o.max_edge = 0.0;
    }
    return o;
}

SceneOptions SceneArgs::options() const {
    SceneOptions o{scene, subdivision(), zone};
    o.merge_coplanar = merge_coplanar;
    return o;
}

nlohmann::json SceneArgs::to_json() const {
    const SubdivisionOptions o = subdivision();
    nlohmann::json j{{"scene", scene}, {"subdivide", o.n}};
    j["max_edge"] = o.max_edge > 0.0 ? nlohmann::json(o.max_edge) : nlohmann::json(nullptr);
    if (!zone.empty()) j["zone"] = zone;
    if (merge_coplanar) j["merge_coplanar"] = true;  // absent when off: reports stay as they were
    return j;
}

void MethodArgs::add_to(CLI::App* cmd) {
    std::string names;
    for (const auto& n : method_names()) names += (names.empty() ? "" : ", ") + n;
    cmd->add_option("--method", method,
                    "Estimator of F" + (names.empty() ? std::string() : " (" + names + ")") +
                        "; default: the most accurate one that handles the scene")
        ->type_name("NAME");
    cmd->add_option("--threads", options.threads, "Worker threads (0 = all cores)")
        ->type_name("T")
        ->capture_default_str();
    cmd->add_option("--tolerance", options.tolerance,
                    "Absolute error target per entry (analytic method; default 1e-10, and 1e-6 "
                    "for the pairs of an obstructed scene that are partly hidden). The method's "
                    "error estimate is checked by the tests against independent values, not "
                    "proven")
        ->type_name("EPS")
        ->capture_default_str()
        ->each([this](const std::string&) { tolerance_given = true; });
    cmd->add_option("--samples", samples,
                    "Monte-Carlo samples per row or pair (0 = the method's default)")
        ->type_name("S")
        ->capture_default_str();
    cmd->add_option("--seed", seed, "Seed of the random streams (Monte-Carlo methods)")
        ->capture_default_str();
    cmd->add_option("--sampler", sampler,
                    "Monte-Carlo point set: sobol, halton, stratified or random")
        ->type_name("NAME")
        ->capture_default_str();
    cmd->add_option("--resolution", options.resolution, "Hemicube / hemiplane cells per side")
        ->type_name("R")
        ->capture_default_str();
    cmd->add_option("--points", options.points, "Hemicube / hemiplane points per patch")
        ->type_name("P")
        ->capture_default_str();
    cmd->add_option("--ray-offset", visibility.relative_epsilon,
                    "Ray tracing (Monte-Carlo methods): ray ends are moved off their patch by "
                    "this fraction of the scene's diagonal")
        ->type_name("EPS")
        ->capture_default_str();
    cmd->add_flag("--robust-rays", visibility.robust,
                  "Ray tracing: Embree's robust mode (no accuracy-reducing shortcuts; slower)");
}

void MethodArgs::validate() const {
    if (samples < 0) throw OptionError("--samples", fmt::format("must be ≥ 0, got {}", samples));
    if (seed < 0) throw OptionError("--seed", fmt::format("must be ≥ 0, got {}", seed));
    formfactor::validate(compute_options());  // parses --sampler and --method on the way
}

MethodOptions MethodArgs::method_options() const {
    MethodOptions o = options;
    o.samples = static_cast<std::uint64_t>(samples);
    o.seed = static_cast<std::uint64_t>(seed);
    o.sampler = parse_sampler(sampler);
    if (tolerance_given) o.obstructed_tolerance = options.tolerance;
    return o;
}

ComputeOptions MethodArgs::compute_options() const {
    ComputeOptions o;
    if (!method.empty()) o.method = parse_method(method);
    o.method_options = method_options();
    o.visibility = visibility;
    return o;
}

MethodKind MethodArgs::resolved_kind(const Scene& scene) const {
    return method.empty() ? default_method(scene) : parse_method(method);
}

nlohmann::json MethodArgs::to_json(const std::string& resolved_method) const {
    return nlohmann::json{
        {"method", resolved_method},
        {"method_given", !method.empty()},
        {"threads", options.threads},
        {"tolerance", options.tolerance},
        {"obstructed_tolerance",
         tolerance_given ? options.tolerance : MethodOptions{}.obstructed_tolerance},
        {"samples", options.samples},
        {"seed", options.seed},
        {"sampler", sampler},
        {"resolution", options.resolution},
        {"points", options.points},
    };
}

Scene prepare_scene(const SceneArgs& args, StepTimes& times,
                    const std::function<DenseRunNeeds(const Scene&)>& needs) {
    if (!needs) return prepare_scene(args.options(), &times);
    return prepare_scene(args.options(), &times, [&](const Scene& scene) {
        DenseRunNeeds run = needs(scene);
        const double count = subdivision_patch_count(scene, args.subdivision());
        // Beyond size_t's reach the estimate is absurd anyway; clamp so the message can say so.
        run.patches = count < 1e18 ? static_cast<std::size_t>(count) : std::size_t(1e18);
        std::size_t surfaces = 0;
        for (const Surface& s : scene.surfaces) surfaces += s.obstruction ? 0 : 1;
        const bool subdivided = run.patches > surfaces;
        std::string advice = subdivided
                                 ? fmt::format(
                                       "use a coarser --subdivide or a larger --max-edge (without "
                                       "either, one patch per surface: N = {})",
                                       surfaces)
                                 : std::string("use a scene with fewer surfaces");
        advice +=
            "; or write a sparse matrix (formfactor compute -o F.mtx or F.h5, with "
            "--threshold T)";
        check_memory(run, available_memory(), advice);
    });
}

ReportContext report_context(const std::string& command, const std::string& method,
                             const SceneArgs& scene, const StepTimes& times, const Stopwatch& total,
                             int threads, const nlohmann::json& details,
                             const ReciprocityPromise& promise) {
    ReportContext ctx;
    ctx.command = command;
    ctx.method = method;
    ctx.options = scene.to_json();
    ctx.timings = times;
    ctx.total_seconds = total.seconds();
    ctx.threads = threads;
    ctx.details = details;
    ctx.reciprocity = promise;
    return ctx;
}

void stage_report(OutputTransaction& tx, const std::string& path, const nlohmann::json& report) {
    const std::string text = json_text(report);
    tx.stage(path, [&](std::ostream& out) {
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
    });
}

void warn_single_patch(Scene& scene) {
    if (scene.patches.size() != 1) return;
    const std::string w =
        "the scene has one patch: F is the 1×1 matrix [0] (a planar patch does not see itself; "
        "there is nothing to exchange with)";
    scene.warnings.push_back(w);
    std::fflush(stdout);
    fmt::print(stderr, "formfactor: warning: {}\n", w);
}

void warn_if_nothing_seen(const Scene& scene, double row_sum_max) {
    const auto& patches = scene.patches;
    if (patches.size() < 2 || row_sum_max > 0.0) return;
    // Patches in one plane facing one way (a subdivided wall) see nothing of each other: no
    // sign of anything wrong.
    const Vec3 n0 = patches[0].normal, c0 = patches[0].centroid;
    double extent = 0.0;
    for (const auto& p : patches) extent = std::max(extent, (p.centroid - c0).norm());
    bool one_plane = true;
    for (std::size_t i = 1; i < patches.size() && one_plane; ++i)
        one_plane = (patches[i].normal - n0).norm() <= 1e-9 &&
                    std::abs(n0.dot(patches[i].centroid - c0)) <= 1e-9 * extent;
    if (one_plane) return;
    std::fflush(stdout);
    fmt::print(stderr,
               "formfactor: warning: no patch sees any other (every row of F sums to 0): their "
               "fronts face away from each other. A closed solid from a CAD tool or Gmsh faces "
               "outwards; reverse its faces' vertex order to compute its inside (`formfactor "
               "info` names the shells that face outwards)\n");
}

std::vector<double> patch_emissivities(const Scene& scene) {
    std::vector<double> e;
    e.reserve(scene.patches.size());
    for (std::size_t i = 0; i < scene.patches.size(); ++i)
        e.push_back(scene.material_of(i).emissivity);
    return e;
}

std::string format_seconds(double s) {
    if (s < 10.0) return fmt::format("{:.3f} s", s);
    if (s < 60.0) return fmt::format("{:.1f} s", s);
    const long long whole = static_cast<long long>(s + 0.5);
    if (whole < 3600) return fmt::format("{} min {:02d} s", whole / 60, whole % 60);
    return fmt::format("{} h {:02d} min", whole / 3600, (whole / 60) % 60);
}

std::string format_timings(const StepTimes& times, double total) {
    std::string out;
    for (const auto& [name, s] : times.steps) {
        out += fmt::format("{}{} {}", out.empty() ? "" : ", ", name, format_seconds(s));
    }
    out += fmt::format("{}total {}", out.empty() ? "" : ", ", format_seconds(total));
    return out;
}

void print_reciprocity(const Diagnostics& d, const ReciprocityPromise& promise) {
    fmt::print("reciprocity {}\n", reciprocity_summary(d, promise));
    if (d.max_reciprocity_defect > 0.0) {
        fmt::print("            worst pair ({}, {}): |A_i F_ij - A_j F_ji| / max(...) = {:.3g}\n",
                   d.reciprocity_i, d.reciprocity_j, d.max_reciprocity_defect);
    }
}

void print_matrix_summary(const Scene& scene, const std::string& method, int threads,
                          const FormFactors& ff, const Diagnostics& d,
                          const ReciprocityPromise& promise, const StepTimes& times, double total) {
    std::size_t obstructions = 0;
    for (const auto& s : scene.surfaces) obstructions += s.obstruction ? 1 : 0;
    fmt::print("scene      {}: {} surfaces, {} obstructions, N = {} patches\n", scene.name,
               scene.surfaces.size() - obstructions, obstructions, d.n);
    fmt::print("method     {} ({} thread{})\n", method, threads, threads == 1 ? "" : "s");
    fmt::print("row sums   min {:.10g}, max {:.10g}, mean {:.10g}\n", d.row_sum_min, d.row_sum_max,
               d.row_sum_mean);
    print_reciprocity(d, promise);
    warn_if_nothing_seen(scene, d.row_sum_max);
    if (ff.standard_error && ff.standard_error->size() > 0) {
        fmt::print("std error  max {:.3g}, mean {:.3g} (per entry)\n",
                   ff.standard_error->maxCoeff(), ff.standard_error->mean());
    }
    if (d.negative_entries || d.entries_above_one || d.nonfinite_entries) {
        fmt::print("warning    {} entries < 0, {} entries > 1, {} non-finite entries\n",
                   d.negative_entries, d.entries_above_one, d.nonfinite_entries);
    }
    fmt::print("time       {}\n", format_timings(times, total));
}

std::string cli_flag(const std::string& field) {
    if (field.empty() || field[0] == '-') return field;
    if (field == "output") return "-o";
    if (field == "rows") return "--rows";
    std::string flag = "--" + field;
    std::replace(flag.begin(), flag.end(), '_', '-');
    return flag;
}

std::string cli_text(const std::string& message) {
    std::string out;
    std::size_t at = 0;
    for (std::size_t open; (open = message.find('`', at)) != std::string::npos;) {
        const std::size_t close = message.find('`', open + 1);
        if (close == std::string::npos) break;
        out += message.substr(at, open - at);
        out += cli_flag(message.substr(open + 1, close - open - 1));
        at = close + 1;
    }
    return out + message.substr(at);
}

bool same_file(const std::string& a, const std::string& b) {
    std::error_code ea, eb;
    const auto ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
    const auto cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
    if (ea || eb)
        return std::filesystem::path(a).lexically_normal() ==
               std::filesystem::path(b).lexically_normal();
    return ca == cb;
}

bool has_extension(const std::string& path, const std::string& ext) {
    std::string e = std::filesystem::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return e == ext;
}

void require_extension(const std::string& path, const std::string& ext, const std::string& option) {
    if (has_extension(path, ext)) return;
    const std::string e = std::filesystem::path(path).extension().string();
    if (e.empty()) {
        throw OptionError(option, "'" + path + "' has no extension (use " + ext + ")");
    }
    throw OptionError(option, "unknown output extension '" + e + "' (use " + ext + ")");
}

}  // namespace formfactor::cli
