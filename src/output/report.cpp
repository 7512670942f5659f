#include "formfactor/output/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <ctime>
#include <limits>
#include <ostream>

#include "formfactor/core/atomic_file.h"
#include "formfactor/matrix/memory.h"
#include "formfactor/scene/closure.h"

namespace formfactor {

using nlohmann::json;

namespace {

const char* promise_name(ReciprocityPromise::Kind k) {
    switch (k) {
        case ReciprocityPromise::Kind::exact:
            return "exact";
        case ReciprocityPromise::Kind::statistical:
            return "statistical";
        case ReciprocityPromise::Kind::approximate:
            return "approximate";
        default:
            return "unknown";
    }
}

}  // namespace

json diagnostics_json(const Diagnostics& d, const ReciprocityPromise& promise) {
    const ReciprocityVerdict v = assess_reciprocity(d, promise);
    json verdict{{"promise", promise_name(promise.kind)}, {"text", v.text}};
    verdict["within"] = v.within ? json(*v.within) : json(nullptr);
    if (promise.kind == ReciprocityPromise::Kind::exact) verdict["tolerance"] = promise.tolerance;
    if (promise.kind == ReciprocityPromise::Kind::statistical && d.has_z) {
        verdict["z_max_limit"] = v.z_max_limit;
        verdict["z_rms_limit"] = v.z_rms_limit;
    }
    json z = nullptr;
    if (d.has_z)
        z = json{{"max", d.z_max},
                 {"rms", d.z_rms},
                 {"pairs", d.z_pairs},
                 {"i", d.z_i},
                 {"j", d.z_j},
                 {"zero_se_pairs", d.z_undefined},
                 {"zero_entries", d.z_zero_entries}};
    return json{
        {"row_sum", {{"min", d.row_sum_min}, {"max", d.row_sum_max}, {"mean", d.row_sum_mean}}},
        {"reciprocity",
         {{"max_defect", d.max_reciprocity_defect},
          {"i", d.reciprocity_i},
          {"j", d.reciprocity_j},
          {"area_weighted", d.reciprocity_area_weighted},
          {"row_relative", {{"max", d.reciprocity_row_max}, {"row", d.reciprocity_row}}},
          {"z", z},
          {"verdict", verdict}}},
        {"negative_entries", d.negative_entries},
        {"entries_above_one", d.entries_above_one},
        {"nonfinite_entries", d.nonfinite_entries},
        {"max_abs_diagonal", d.max_abs_diagonal},
    };
}

namespace {

json vec_json(const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

}  // namespace

json scene_summary_json(const Scene& scene) {
    std::size_t obstructions = 0;
    for (const auto& s : scene.surfaces) obstructions += s.obstruction ? 1 : 0;
    double total = 0.0;
    double amin = std::numeric_limits<double>::infinity();
    double amax = 0.0;
    for (const auto& p : scene.patches) {
        total += p.area;
        amin = std::min(amin, p.area);
        amax = std::max(amax, p.area);
    }
    if (scene.patches.empty()) amin = 0.0;
    Bounds3 b;
    for (const auto& s : scene.surfaces) {
        for (const auto& v : s.polygon.vertices) b.extend(v);
    }
    json j{
        {"name", scene.name},
        {"title", scene.title},
        {"surfaces", scene.surfaces.size() - obstructions},
        {"obstructions", obstructions},
        {"patches", scene.patches.size()},
        {"materials", scene.materials.size()},
        {"enclosure", scene.enclosure},
        {"closed", check_closure(scene).closed},
        {"total_area", total},
        {"patch_area", {{"min", amin}, {"max", amax}}},
        {"warnings", scene.warnings},
    };
    if (b.empty()) {
        j["bounds"] = nullptr;
    } else {
        j["bounds"] = {{"min", vec_json(b.lo)}, {"max", vec_json(b.hi)}};
    }
    return j;
}

std::string utc_timestamp() {
    const std::time_t now = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&now, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

json standard_error_json(const FormFactors& ff) {
    if (!ff.standard_error || ff.standard_error->size() == 0) return nullptr;
    const DenseMatrix& se = *ff.standard_error;
    return json{{"max", se.maxCoeff()}, {"mean", se.mean()}};
}

std::string reciprocity_summary(const Diagnostics& d, const ReciprocityPromise& promise) {
    const ReciprocityVerdict v = assess_reciprocity(d, promise);
    std::string s =
        fmt::format("area-weighted {:.2g}, worst row {:.2g} (patch {})",
                    d.reciprocity_area_weighted, d.reciprocity_row_max, d.reciprocity_row);
    if (d.has_z) s += fmt::format(", z max {:.3g} RMS {:.3g}", d.z_max, d.z_rms);
    return s + ": " + v.text;
}

namespace {

// The one place that writes the report's top-level keys; `rows` is a block's [first, end).
json assemble_report(const Scene& scene, std::size_t n, const ReportContext& ctx,
                     const json& rows) {
    json timings = json::object();
    for (const auto& [name, seconds] : ctx.timings.steps) timings[name] = seconds;
    timings["total"] = std::max(ctx.total_seconds, ctx.timings.sum());
    json report{
        {"formfactor_version", FF_VERSION},
        {"timestamp", utc_timestamp()},
        {"command", ctx.command},
        {"scene", scene_summary_json(scene)},
        {"N", n},
        {"method", ctx.method},
        {"options", ctx.options},
        {"threads", ctx.threads},
        {"timings", timings},
        {"details", ctx.details},
        {"outputs", ctx.outputs},
    };
    const std::pair<const char*, const json*> sections[] = {
        {"storage", &ctx.storage},         {"diagnostics", &ctx.diagnostics},
        {"memory", &ctx.memory},           {"repair", &ctx.repair},
        {"per_surface", &ctx.per_surface}, {"solve", &ctx.solve},
        {"render", &ctx.render},           {"rows", &rows}};
    for (const auto& [key, section] : sections) {
        if (!section->is_null()) report[key] = *section;
    }
    if (!ctx.note.empty()) report["note"] = ctx.note;
    return report;
}

}  // namespace

json make_report(const Scene& scene, std::size_t n, const ReportContext& ctx) {
    return assemble_report(scene, n, ctx, nullptr);
}

json make_report(const Scene& scene, const FormFactors& ff, ReportContext ctx) {
    if (ff.is_block()) {
        ctx.diagnostics = {{"standard_error", standard_error_json(ff)}};
        return assemble_report(scene, ff.areas.size(), ctx,
                               json::array({ff.first_row, ff.first_row + ff.size()}));
    }
    ctx.diagnostics = diagnostics_json(diagnose(ff), ctx.reciprocity);
    ctx.diagnostics["standard_error"] = standard_error_json(ff);
    ctx.memory = memory_json();
    return assemble_report(scene, ff.size(), ctx, nullptr);
}

json memory_json() { return {{"peak_bytes", peak_memory_bytes()}}; }

std::string json_text(const json& j) { return j.dump(2) + "\n"; }

void write_json_file(const std::string& path, const json& j) {
    const std::string text = json_text(j);
    write_file_atomically(path, [&](std::ostream& out) {
        out.write(text.data(), static_cast<std::streamsize>(text.size()));
    });
}

namespace {

// The diagnostics block of the repair report (its own shape, kept for the report contract).
nlohmann::json repair_diagnostics_json(const Diagnostics& d) {
    return {{"n", d.n},
            {"row_sum_min", d.row_sum_min},
            {"row_sum_max", d.row_sum_max},
            {"row_sum_mean", d.row_sum_mean},
            {"max_reciprocity_defect", d.max_reciprocity_defect},
            {"reciprocity_pair", {d.reciprocity_i, d.reciprocity_j}},
            {"reciprocity_area_weighted", d.reciprocity_area_weighted},
            {"reciprocity_row_max", d.reciprocity_row_max},
            {"negative_entries", d.negative_entries},
            {"entries_above_one", d.entries_above_one},
            {"nonfinite_entries", d.nonfinite_entries},
            {"max_abs_diagonal", d.max_abs_diagonal}};
}

}  // namespace

nlohmann::json to_json(const RepairReport& r) {
    return {{"mode", to_string(r.mode)},
            {"before", repair_diagnostics_json(r.before)},
            {"after", repair_diagnostics_json(r.after)},
            {"max_abs_change", r.max_abs_change},
            {"max_relative_change", r.max_relative_change},
            {"negatives_cleared", r.negatives_cleared},
            {"diagonal_cleared", r.diagonal_cleared},
            {"closure_iterations", r.closure_iterations},
            {"closure_residual", r.closure_residual},
            {"rows_not_closable", r.rows_not_closable},
            {"warnings", r.warnings}};
}

nlohmann::json to_json(const Fields& f) {
    switch (f.kind()) {
        case Fields::Kind::null:
            return nullptr;
        case Fields::Kind::boolean:
            return f.boolean();
        case Fields::Kind::integer:
            return f.integer();
        case Fields::Kind::unsigned_integer:
            return f.unsigned_integer();
        case Fields::Kind::real:
            return f.real();
        case Fields::Kind::text:
            return f.text();
        case Fields::Kind::reals:
            return f.reals();
        case Fields::Kind::object: {
            nlohmann::json j = nlohmann::json::object();
            for (std::size_t k = 0; k < f.keys().size(); ++k)
                j[f.keys()[k]] = to_json(f.values()[k]);
            return j;
        }
    }
    return nullptr;
}

}  // namespace formfactor
