// `formfactor compute SCENE -o OUT [--report REPORT.json] [--patches PATCHES.csv]
//  [--stderr SE] [--per-surface | --per-patch] [--storage auto|dense|sparse] [--threshold T]`

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

#include "all_zones.h"
#include "commands.h"
#include "common.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/matrix/hierarchical.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/methods/traits.h"
#include "formfactor/output/energyplus_view_factors.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/report.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/output/vtu.h"
#include "formfactor/pipeline_solve.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/energyplus.h"
#include "solve_common.h"
#include "sparse_common.h"

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
    std::string storage = "auto";  ///< --storage auto|dense|sparse|hierarchical
    double threshold = 0.0;        ///< --threshold T (sparse storage)
    double error_target = 1e-6;    ///< --error-target (hierarchical storage)
    long long row = -1;            ///< --row I (a .vtu output: F's row I as a field)
    std::string pairs;             ///< --pairs PAIRS.csv (per-surface long table)
    bool row_sums = false;         ///< --row-sums (columns of --patches)
    bool all_zones = false;        ///< --all-zones (EnergyPlus models)
};

// -o outputs that are not a matrix file: they need the scene beside F.
bool is_vtu_path(const std::string& path) { return has_extension(path, ".vtu"); }

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

// The emissivity of each group's own surface (its first), as the per-surface matrix files say.
std::vector<double> group_emissivities(const Scene& scene, const PatchGroups& groups) {
    std::vector<double> emissivities;
    for (const auto& members : groups.surfaces)
        emissivities.push_back(
            scene.material_of_surface(static_cast<std::size_t>(members.front())).emissivity);
    return emissivities;
}

// Hierarchical storage (formfactor/matrix/hierarchical.h): the per-surface matrix from the
// operator's products (one column per surface), F never formed; over the ranks under mpirun.
void run_compute_hierarchical(const ComputeArgs& args, OutputTransaction* outer) {
    Stopwatch total;
    if (!rows_per_surface(args))
        throw OptionError("--storage",
                          "hierarchical storage writes the per-surface matrix (--per-surface); "
                          "the patch matrix is N x N: use dense or sparse storage for it");
    if (!args.standard_error.empty())
        throw OptionError("--stderr",
                          "the hierarchical operator has analytic entries (no standard "
                          "errors)");
    if (parse_repair_mode(args.repair.mode) != RepairMode::none)
        throw OptionError("--repair",
                          "needs the entries of F; the hierarchical operator is "
                          "reciprocal by construction (--repair none)");
    if (args.threshold > 0.0) throw OptionError("--threshold", "applies to sparse storage");
    if (!(args.error_target > 0.0 && args.error_target <= 0.1))
        throw OptionError("--error-target", "must be in (0, 0.1]");  // before the work
    if (!args.method.method.empty() && parse_method(args.method.method) != MethodKind::analytic)
        throw OptionError("--method", "hierarchical storage computes analytic entries");
    const int threads = effective_threads(args.method.options.threads);
    StepTimes times;
    Scene scene = prepare_scene(args.scene, times);
    warn_single_patch(scene);
    // Under mpirun the blocks are built and applied over the ranks (the same bits as one
    // process); else the operator is this process's.
    const HeldOperator held = held_operator(scene, args.error_target, threads, times);
    Stopwatch sw;
    const SurfaceFormFactors<FormFactors> surfaces =
        held.spread ? distributed::per_surface(scene, *held.spread, threads)
                    : per_surface(scene, *held.whole, threads);
    const PatchGroups& groups = surfaces.groups;
    const FormFactors& written = *surfaces.aggregated;
    times.add("per-surface products", sw.lap());
    MatrixFileInfo info;
    info.areas = written.areas;
    info.emissivities = group_emissivities(scene, groups);
    info.enclosure = scene.enclosure;
    OutputTransaction tx;
    tx.stage(args.output, [&](std::ostream& out) {
        write_matrix(out, matrix_format_for(args.output), written.F, info);
    });
    if (!args.patches.empty())
        tx.stage(args.patches, [&](std::ostream& out) { write_patch_table(out, scene); });
    times.add("write", sw.lap());
    const HierarchicalStats& hs = held.stats();
    const Diagnostics d = diagnose(written);
    if (!args.report.empty()) {
        nlohmann::json details = {{"hierarchical", to_json(hs)}};
        if (held.spread) details["mpi"] = to_json(*held.spread);
        ReportContext ctx = report_context("compute", "analytic (hierarchical operator)",
                                           args.scene, times, total, threads, details, {});
        ctx.options.update(args.method.to_json("analytic"));
        ctx.options["storage"] = "hierarchical";
        ctx.options["error_target"] = args.error_target;
        ctx.options["output"] = args.output;
        ctx.options["report"] = args.report;
        ctx.outputs = {{"matrix", args.output}, {"report", args.report}};
        ctx.storage = {{"kind", "hierarchical"}, {"operator_bytes", hs.bytes}};
        ctx.memory = memory_json();
        ctx.per_surface = {{"N", written.size()}, {"diagnostics", diagnostics_json(d)}};
        stage_report(tx, args.report, make_report(scene, scene.patches.size(), ctx));
    }
    finish(tx, outer);
    fmt::print("scene      {}: N = {} patches, {} surfaces; rows sum to {:.9f} .. {:.9f}\n",
               scene.name, scene.patches.size(), written.size(), d.row_sum_min, d.row_sum_max);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = args.output;
    if (!args.patches.empty()) wrote += ", " + args.patches;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, outer);
}

// Sparse storage (formfactor/pipeline_sparse.h): rows in blocks into CSR, written as .mtx or
// .h5; `why` says why it was picked.
void run_compute_sparse(const ComputeArgs& args, const std::string& why, OutputTransaction* outer) {
    Stopwatch total;
    StepTimes times;
    Scene scene = prepare_scene(args.scene, times);
    warn_single_patch(scene);
    const MethodKind method = args.method.resolved_kind(scene);
    if (!args.standard_error.empty() &&
        !method_traits(method, args.method.options, &scene).standard_errors)
        throw OptionError("--stderr", "method '" + to_string(method) +
                                          "' gives no standard errors (it is exact; the "
                                          "Monte-Carlo methods give them)");
    const SparseComputeResult r =
        compute_sparse_matrix(scene, args.method, args.repair, args.threshold, times);
    Stopwatch sw;
    // --per-surface: the surfaces' matrix, aggregated on the CSR (rows are surfaces; the .h5
    // file then has no patch table).
    std::optional<SurfaceFormFactors<SparseFormFactors>> surfaces;
    if (args.per_surface) {
        surfaces = per_surface(scene, r.form_factors);
        times.add("per surface", sw.lap());
    }
    const SparseFormFactors& F = surfaces ? surfaces->of(r.form_factors) : r.form_factors;

    // The report and the patch table are staged first, the matrix written, then both renamed.
    OutputTransaction tx;
    if (!args.patches.empty())
        tx.stage(args.patches, [&](std::ostream& out) { write_patch_table(out, scene); });
    if (!args.report.empty()) {
        ReportContext ctx = report_context("compute", to_string(method), args.scene, times, total,
                                           effective_threads(args.method.options.threads),
                                           nlohmann::json::object(), {});
        ctx.options.update(args.method.to_json(to_string(method)));
        ctx.options["storage"] = "sparse";
        ctx.options["threshold"] = args.threshold;
        ctx.options["repair"] = args.repair.mode;
        ctx.options["per_surface"] = args.per_surface;
        ctx.options["output"] = args.output;
        ctx.outputs = {{"matrix", args.output}};
        add_sparse_sections(r, why, args.threshold, args.repair.mode, ctx);
        if (args.per_surface) ctx.per_surface = {{"N", F.n}, {"nonzeros", F.nonzeros()}};
        stage_report(tx, args.report, make_report(scene, scene.patches.size(), ctx));
    }
    SparseFileInfo info;
    info.scene = scene.name;
    info.method = to_string(method);
    info.repair = args.repair.mode;
    info.patches = surfaces && surfaces->aggregated ? nullptr : &scene.patches;
    // --stderr: the standard error of each stored entry, in F's pattern (a matrix of its own,
    // .mtx or .h5).
    if (!args.standard_error.empty()) {
        if (!F.standard_error)
            throw Error("compute: the sparse run kept no standard errors");  // cannot happen
        SparseFormFactors E;
        E.n = F.n;
        E.indptr = F.indptr;
        E.indices = F.indices;
        E.values = *F.standard_error;
        E.areas = F.areas;
        E.threshold = F.threshold;
        E.computed_row_sums.assign(F.n, 0.0);
        for (std::size_t i = 0; i < F.n; ++i)
            for (auto k = F.indptr[i]; k < F.indptr[i + 1]; ++k)
                E.computed_row_sums[i] += E.values[static_cast<std::size_t>(k)];
        E.dropped.assign(F.n, 0.0);
        SparseFileInfo se_info = info;
        se_info.method += " (standard errors of the entries)";
        tx.stage_file(args.standard_error,
                      [&](const std::string& staged) { write_sparse_matrix(staged, E, se_info); });
    }
    tx.stage_file(args.output,
                  [&](const std::string& staged) { write_sparse_matrix(staged, F, info); });
    finish(tx, outer);
    times.add("write", sw.lap());

    const int threads = effective_threads(args.method.options.threads);
    const double n = static_cast<double>(F.n);
    fmt::print("scene      {}: N = {} patches\n", scene.name,
               format_count(double(scene.patches.size())));
    fmt::print("method     {} ({} thread{})\n", to_string(method), threads,
               threads == 1 ? "" : "s");
    print_sparse_summary(scene, r, why, args.threshold, args.repair.mode);
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    std::string wrote = fmt::format(
        "{} (sparse, {}×{}{}, {} entries)", args.output, format_count(n), format_count(n),
        args.per_surface ? " per surface" : "", format_count(double(F.nonzeros())));
    if (!args.patches.empty()) wrote += ", " + args.patches;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, outer);
}

// --all-zones into one EnergyPlus file (.idf or .epJSON): one
// ZoneProperty:UserViewFactors:BySurfaceName object per zone.
void run_compute_all_zones_energyplus(const ComputeArgs& args, EnergyPlusSyntax syntax,
                                      const std::vector<std::string>& zone_names) {
    Stopwatch total;
    if (!args.report.empty() || !args.patches.empty() || !args.pairs.empty() ||
        !args.standard_error.empty())
        throw OptionError("--all-zones",
                          "with -o .idf or .epJSON writes one file; --report, --patches, --pairs "
                          "and --stderr go with a matrix file per zone (-o F.npy) or one zone "
                          "(--zone NAME)");
    if (args.output.find("{zone}") != std::string::npos)
        throw OptionError("-o",
                          "an EnergyPlus file holds every zone (one object per zone): "
                          "its name takes no {zone}");
    if (args.per_patch) throw OptionError("--per-patch", "EnergyPlus view factors are per surface");
    if (args.storage != "auto" && args.storage != "dense")
        throw OptionError("--storage", "EnergyPlus view factors are written from the dense F");
    check_output_directory(args.output);
    StepTimes times;
    std::vector<ZoneViewFactors> zones;
    for (const std::string& zone : zone_names) {
        SceneArgs one = args.scene;
        one.zone = zone;
        const Scene scene = prepare_scene(one, times);
        const ComputedMatrix computed = compute_matrix(scene, args.method, args.repair, times);
        const SurfaceFormFactors<FormFactors> surfaces = per_surface(scene, computed.ff);
        const FormFactors& by_surface = surfaces.of(computed.ff);
        const Diagnostics d = diagnose(by_surface);
        fmt::print("zone       {}: {} surfaces, {} patches; rows sum to {:.10g} .. {:.10g}\n",
                   scene.title, by_surface.size(), scene.patches.size(), d.row_sum_min,
                   d.row_sum_max);
        zones.push_back({scene.title, surfaces.groups.names, by_surface.F});
    }
    write_file_atomically(
        args.output, [&](std::ostream& out) { write_energyplus_view_factors(out, syntax, zones); });
    fmt::print("time       {}\n", format_timings(times, total.seconds()));
    fmt::print("wrote      {} ({} zones)\n", args.output, zones.size());
}

void run_compute(const ComputeArgs& args, OutputTransaction* outer);

// --all-zones: every zone of an EnergyPlus model, each its own enclosure and matrix. EnergyPlus
// outputs hold every zone in one file; any other -o (and --report, --patches, --pairs,
// --stderr) is one file per zone, named by zone_file(). The zones' files are written together
// after the last zone, or not at all.
void run_compute_all_zones(const ComputeArgs& args) {
    const std::vector<std::string> zones = all_zones(args.scene, "computes");
    if (args.output.empty())
        throw OptionError("-o",
                          "an output file is required (.idf or .epJSON for all zones in "
                          "one file; .csv, .npy, .txt, .dat, .vtu, .mtx or .h5 for a file "
                          "per zone)");
    EnergyPlusSyntax syntax = EnergyPlusSyntax::Idf;
    if (energyplus_syntax_for(args.output, syntax)) {
        run_compute_all_zones_energyplus(args, syntax, zones);
        return;
    }

    // Every zone's file names, checked before any work: two zones whose names differ only in
    // what zone_file() replaces would write one file.
    Stopwatch total;
    std::vector<ComputeArgs> runs;
    ZoneOutputs outputs;
    for (const std::string& zone : zones) {
        ComputeArgs one = args;
        one.all_zones = false;
        one.scene.zone = zone;
        for (std::string* path :
             {&one.output, &one.report, &one.patches, &one.pairs, &one.standard_error})
            outputs.claim(*path, zone);
        runs.push_back(std::move(one));
    }
    OutputTransaction tx;
    for (const ComputeArgs& one : runs) {
        fmt::print("zone       {}\n", one.scene.zone);
        run_compute(one, &tx);
    }
    const std::vector<std::string> files = tx.paths();
    tx.commit();
    fmt::print("time       all zones {:.3g} s\n", total.seconds());
    fmt::print("wrote      {} files for {} zones\n", files.size(), zones.size());
}

void run_compute(const ComputeArgs& args, OutputTransaction* outer) {
    Stopwatch total;
    if (args.all_zones) {
        args.scene.validate();
        args.method.validate();
        parse_repair_mode(args.repair.mode);
        run_compute_all_zones(args);
        return;
    }
    // Every option and output path is checked before any work.
    args.scene.validate();
    args.method.validate();
    parse_repair_mode(args.repair.mode);
    if (EnergyPlusSyntax input_syntax = EnergyPlusSyntax::Idf;
        args.scene.zone.empty() && energyplus_syntax_for(args.scene.scene, input_syntax)) {
        const std::vector<std::string> zones = energyplus_zones(args.scene.scene);
        if (zones.size() > 1)
            throw OptionError("--zone",
                              fmt::format("{} has {} zones ({}): choose one with --zone "
                                          "NAME, or compute each with --all-zones",
                                          args.scene.scene, zones.size(), fmt::join(zones, ", ")));
    }
    if (args.output.empty()) {
        throw OptionError("-o",
                          "an output file is required (.csv, .npy, .txt, .dat, .vtu, .mtx or .h5)");
    }
    const bool vtu = is_vtu_path(args.output);
    EnergyPlusSyntax ep_syntax = EnergyPlusSyntax::Idf;
    const bool energyplus = energyplus_syntax_for(args.output, ep_syntax);
    if (energyplus && args.per_patch)
        throw OptionError("--per-patch",
                          "EnergyPlus view factors are per surface (-o .idf or .epJSON)");
    if (energyplus && args.storage != "auto" && args.storage != "dense")
        throw OptionError("--storage", "EnergyPlus view factors are written from the dense F");
    if (args.row >= 0 && !vtu)
        throw OptionError("--row", "puts a row of F into a .vtu output (-o F.vtu)");
    if (args.row < -1) throw OptionError("--row", "must be a patch index ≥ 0");
    if (vtu && args.per_surface)
        throw OptionError("--per-surface", "a .vtu file holds the patches (one cell per patch)");
    if (vtu && args.storage != "auto" && args.storage != "dense")
        throw OptionError("--storage", "a .vtu output is written from the dense F");
    if (args.row_sums && args.patches.empty())
        throw OptionError("--row-sums", "adds columns to the patch table (--patches P.csv)");
    if (!args.pairs.empty()) {
        require_extension(args.pairs, ".csv", "--pairs");
        check_output_directory(args.pairs);
        if (same_file(args.pairs, args.output))
            throw OptionError("--pairs", "is the same file as -o");
    }
    if (args.storage != "auto" && args.storage != "dense" && args.storage != "sparse" &&
        args.storage != "hierarchical")
        throw OptionError(
            "--storage", "must be auto, dense, sparse or hierarchical, got '" + args.storage + "'");
    if (!(args.threshold >= 0.0) || !std::isfinite(args.threshold))
        throw OptionError("--threshold", "must be a finite number ≥ 0");
    const bool sparse_file = is_sparse_matrix_path(args.output);
    if (args.storage == "sparse" && !sparse_file)
        throw OptionError("--storage", "sparse storage writes .mtx or .h5 files (-o F.mtx)");
    if (args.storage == "dense" && sparse_file)
        throw OptionError("--storage",
                          "dense storage writes .csv, .npy or .txt; .mtx and .h5 are written "
                          "by sparse storage (--storage sparse or auto)");
    if (!sparse_file && args.threshold > 0.0)
        throw OptionError("--threshold", "applies to sparse storage (-o F.mtx or F.h5)");
    if (!sparse_file && !vtu && !energyplus) {
        const std::string ext = std::filesystem::path(args.output).extension().string();
        if (ext.empty())
            throw OptionError("-o", "'" + args.output +
                                        "' has no extension (use .csv, .npy, .txt, .dat, .vtu, "
                                        ".idf, .epJSON, .mtx or .h5)");
        if (std::string lower = ext; true) {
            std::transform(lower.begin(), lower.end(), lower.begin(),
                           [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
            if (lower != ".csv" && lower != ".npy" && lower != ".txt" && lower != ".dat")
                throw OptionError("-o", "unknown output extension '" + lower +
                                            "' (use .csv, .npy, .txt, .dat, .vtu, .idf, .epJSON, "
                                            ".mtx or .h5)");
        }
    }
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
            (!args.report.empty() && same_file(args.patches, args.report)) ||
            (!args.pairs.empty() && same_file(args.patches, args.pairs))) {
            throw OptionError("--patches", "is the same file as another output");
        }
    }

    if (!args.standard_error.empty()) {
        if (sparse_file != is_sparse_matrix_path(args.standard_error))
            throw OptionError("--stderr", sparse_file
                                              ? "with sparse storage the standard errors are a "
                                                "sparse matrix too: .mtx or .h5 (F's pattern)"
                                              : "with dense storage: .csv, .npy or .txt, as -o");
        if (!sparse_file) matrix_format_for(args.standard_error, "--stderr");
        check_output_directory(args.standard_error);
        for (const std::string* other : {&args.output, &args.report, &args.patches}) {
            if (!other->empty() && same_file(args.standard_error, *other)) {
                throw OptionError("--stderr", "is the same file as another output");
            }
        }
    }

    if ((sparse_file || args.storage == "hierarchical") && (args.row_sums || !args.pairs.empty()))
        throw OptionError(args.row_sums ? "--row-sums" : "--pairs",
                          "is written from the dense F (--storage dense)");
    if (args.storage == "hierarchical") {
        if (sparse_file)
            throw OptionError("--storage",
                              "hierarchical storage writes the per-surface matrix "
                              "as .csv, .npy or .txt");
        run_compute_hierarchical(args, outer);
        return;
    }
    if (sparse_file) {
        std::string why = args.storage == "sparse" ? "asked for" : "auto: -o is a sparse format";
        if (args.storage == "auto") {
            // Say also whether the dense matrix would have fitted comfortably (half of what is
            // available now).
            Scene probe = load_scene(args.scene.options());
            const double count = subdivision_patch_count(probe, args.scene.subdivision());
            DenseRunNeeds needs;
            needs.patches = count < 1e18 ? static_cast<std::size_t>(count) : std::size_t(1e18);
            const double dense = estimate_dense_memory(needs).total();
            const double available = available_memory();
            why += fmt::format(
                "; dense F would need {}{}", format_bytes(dense),
                available > 0.0 && dense > 0.5 * available
                    ? fmt::format(", more than half of the {} available", format_bytes(available))
                    : "");
        }
        run_compute_sparse(args, why, outer);
        return;
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

    // What -o and --stderr hold: the patch matrix, or the per-surface one (rows = surfaces). A
    // .vtu file holds the patches.
    const bool by_surface = energyplus || (!vtu && rows_per_surface(args));
    // The surfaces' matrix, for -o or --pairs: every surface one patch, in order, is the patch
    // matrix (no copy).
    std::optional<SurfaceFormFactors<FormFactors>> surfaces;
    if (by_surface || !args.pairs.empty()) surfaces = per_surface(scene, ff);
    if (by_surface) times.add("aggregate", sw.lap());
    const FormFactors& written = by_surface ? surfaces->of(ff) : ff;
    const std::vector<double> emissivities =
        by_surface ? group_emissivities(scene, surfaces->groups) : patch_emissivities(scene);

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
    if (vtu) {
        const std::vector<VtuField> fields = form_factor_fields(
            ff, args.row >= 0 ? std::optional<std::size_t>(static_cast<std::size_t>(args.row))
                              : std::nullopt);
        tx.stage(args.output, [&](std::ostream& out) { write_vtu(out, scene, fields); });
    } else if (energyplus) {
        // The zone: an EnergyPlus model's (Scene::title), else the title or the file's stem.
        const std::string zone =
            !scene.title.empty() ? scene.title : std::filesystem::path(scene.name).stem().string();
        tx.stage(args.output, [&](std::ostream& out) {
            write_energyplus_view_factors(out, ep_syntax, zone, surfaces->groups.names, written.F);
        });
    } else {
        stage_matrix(args.output, written.F);
    }
    if (!args.pairs.empty()) {
        // The per-surface matrix whatever -o holds: names are the surfaces'.
        tx.stage(args.pairs, [&](std::ostream& out) {
            write_pairs_csv(out, surfaces->groups.names, surfaces->of(ff).F);
        });
    }
    if (!args.standard_error.empty()) {
        if (!written.standard_error) {
            throw OptionError("--stderr", "method '" + to_string(method) +
                                              "' gives no standard errors (it is exact; "
                                              "the Monte-Carlo methods give them)");
        }
        stage_matrix(args.standard_error, *written.standard_error);
    }
    if (!args.patches.empty()) {
        if (args.row_sums) {
            std::vector<double> sums(ff.size());
            for (std::size_t i = 0; i < sums.size(); ++i)
                sums[i] = ff.F.row(static_cast<Eigen::Index>(i)).sum();
            tx.stage(args.patches, [&](std::ostream& out) { write_patch_table(out, scene, sums); });
        } else {
            tx.stage(args.patches, [&](std::ostream& out) { write_patch_table(out, scene); });
        }
    }
    times.add("write", sw.lap());

    const int threads = effective_threads(args.method.options.threads);
    // Of the matrix written: the pipeline's, after the repair when there was one.
    const Diagnostics& d = repaired ? repaired->after : computed.raw;
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
        ctx.options["per_surface"] = by_surface;
        ctx.outputs["report"] = args.report;
        ctx.options["repair"] = args.repair.mode;
        if (repaired) ctx.repair = to_json(*repaired);
        if (by_surface) {
            const PatchGroups& groups = surfaces->groups;
            // The report describes the patch computation; this block the matrix in -o.
            nlohmann::json rows = nlohmann::json::array();
            for (std::size_t g = 0; g < groups.size(); ++g) {
                nlohmann::json members = nlohmann::json::array();
                for (int m : groups.surfaces[g]) members.push_back(m);
                rows.push_back(
                    {{"name", groups.names[g]}, {"area", written.areas[g]}, {"surfaces", members}});
            }
            ctx.per_surface = {
                {"N", written.size()},
                {"rows", rows},
                {"diagnostics", diagnostics_json(diagnose(written), traits.reciprocity)}};
        }
        stage_report(tx, args.report, make_report(scene, ff, ctx));
    }
    finish(tx, outer);

    print_matrix_summary(scene, to_string(method), threads, ff, d, traits.reciprocity, times,
                         total.seconds());
    if (by_surface) {
        const Diagnostics ds = diagnose(written);
        fmt::print(
            "per surface {} rows (surfaces, subsurfaces cut out, cmb combined); row sums "
            "min {:.10g}, max {:.10g}\n",
            written.size(), ds.row_sum_min, ds.row_sum_max);
    }
    std::string wrote = vtu ? fmt::format("{} ({} cells)", args.output, scene.patches.size())
                            : fmt::format("{} ({}×{}{})", args.output, written.F.rows(),
                                          written.F.cols(), by_surface ? ", per surface" : "");
    if (!args.pairs.empty()) wrote += ", " + args.pairs;
    if (!args.standard_error.empty()) wrote += ", " + args.standard_error;
    if (!args.patches.empty()) wrote += ", " + args.patches;
    if (!args.report.empty()) wrote += ", " + args.report;
    print_wrote(wrote, outer);
}

}  // namespace

void add_compute_command(CLI::App& app) {
    auto args = std::make_shared<ComputeArgs>();
    CLI::App* cmd = app.add_subcommand(
        "compute",
        "Compute the form-factor matrix F of a scene (F_ij from patch i to patch j, row i = "
        "patch i) and write it to a .csv, .npy or .txt (View3D 3.2) file, or sparse to a .mtx "
        "(Matrix Market) or .h5 (HDF5) file");
    args->scene.add_to(cmd);
    args->method.add_to(cmd);
    args->repair.add_to(cmd);
    cmd->add_option("-o,--output", args->output,
                    "Matrix file: .csv (N×N, %.17g), .npy (float64), .txt (View3D 3.2 text) or "
                    ".dat (Elmer's view factors); .vtu: the patches with area, row sum and sky "
                    "factor for ParaView; .idf or .epJSON: EnergyPlus's "
                    "ZoneProperty:UserViewFactors:BySurfaceName (per surface; "
                    "docs/formats-energyplus-solvers.md); sparse: .mtx "
                    "(Matrix Market coordinate) or .h5 (HDF5 CSR, docs/sparse.md)")
        ->type_name("OUT");
    cmd->add_option("--report", args->report,
                    "Also write a JSON report (options, timings, diagnostics)")
        ->type_name("REPORT.json");
    cmd->add_option("--patches", args->patches,
                    "Also write the patch table (index, surface, area, centroid, normal) as CSV")
        ->type_name("PATCHES.csv");
    cmd->add_option("--row", args->row,
                    "With -o F.vtu: also the row F_Ij of patch I as a field (F_from_I)")
        ->type_name("I");
    cmd->add_option("--pairs", args->pairs,
                    "Also write the per-surface matrix as a long table from,to,F with the "
                    "surface names")
        ->type_name("PAIRS.csv");
    cmd->add_flag("--all-zones", args->all_zones,
                  "EnergyPlus models: every zone, each its own enclosure and matrix; -o .idf or "
                  ".epJSON: one file (a ZoneProperty:UserViewFactors:BySurfaceName per zone); "
                  "any other -o, --report, --patches, --pairs, --stderr: a file per zone, the "
                  "zone's name in place of {zone} or before the extension (F.npy -> "
                  "F_ZONE.npy)");
    cmd->add_flag("--row-sums", args->row_sums,
                  "Add the columns row_sum and sky_factor (1 - row sum) to the --patches table");
    cmd->add_option("--stderr,--standard-error", args->standard_error,
                    "Also write the standard error of each entry (same formats as -o; "
                    "with sparse storage .mtx or .h5, F's pattern; Monte-Carlo methods only)")
        ->type_name("SE");
    auto* ps = cmd->add_flag(
        "--per-surface", args->per_surface,
        "Write one row per surface (View3D's output): A_G F_GH = sum of A_i F_ij over the "
        "patches of G and H, VS3 cmb surfaces merged into their target (default for .vs3 input)");
    auto* pp = cmd->add_flag("--per-patch", args->per_patch,
                             "Write one row per patch (default for built-in scenes and .obj)");
    ps->excludes(pp);
    cmd->add_option("--storage", args->storage,
                    "auto (default: sparse for -o .mtx or .h5, dense otherwise, and says which), "
                    "dense (N×N in memory), sparse (rows in blocks into CSR; the dense matrix "
                    "is never made) or hierarchical (per-surface factors from a compressed "
                    "operator, scenes without obstructions: docs/hierarchical.md)")
        ->type_name("KIND");
    cmd->add_option("--error-target", args->error_target,
                    "Hierarchical storage: relative error of each compressed block")
        ->type_name("T")
        ->capture_default_str();
    cmd->add_option("--threshold", args->threshold,
                    "Sparse storage: drop entries F_ij ≤ T, keeping the dropped mass per row "
                    "(--repair reciprocity then restores reciprocity without raising a row sum)")
        ->type_name("T");
    cmd->callback([args] { run_compute(*args, nullptr); });
}

}  // namespace formfactor::cli
