// `formfactor info SCENE [--subdivide N | --max-edge L] [--json]`

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "commands.h"
#include "common.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/output/report.h"
#include "formfactor/scene/closure.h"

namespace formfactor::cli {

namespace {

struct InfoArgs {
    SceneArgs scene;
    bool json = false;
    bool all = false;
};

nlohmann::json rgb_json(const Rgb& c) { return nlohmann::json::array({c.x(), c.y(), c.z()}); }

nlohmann::json info_json(const Scene& scene, const std::vector<std::size_t>& patch_counts) {
    nlohmann::json j;
    j["scene"] = scene_summary_json(scene);
    nlohmann::json surfaces = nlohmann::json::array();
    for (std::size_t k = 0; k < scene.surfaces.size(); ++k) {
        const Surface& s = scene.surfaces[k];
        nlohmann::json sj{{"index", k},
                          {"name", s.name},
                          {"vertices", s.polygon.size()},
                          {"area", area(s.polygon)},
                          {"material", s.material},
                          {"obstruction", s.obstruction},
                          {"patches", patch_counts[k]}};
        if (s.base >= 0) sj["base"] = s.base;
        if (s.combine >= 0) sj["combine"] = s.combine;
        if (!s.where.file.empty()) {
            sj["where"] =
                s.where.line > 0 ? fmt::format("{}:{}", s.where.file, s.where.line) : s.where.file;
        }
        surfaces.push_back(sj);
    }
    j["surfaces"] = surfaces;
    nlohmann::json materials = nlohmann::json::array();
    for (const Material& m : scene.materials) {
        materials.push_back(
            {{"name", m.name},
             {"reflectance", rgb_json(m.reflectance)},
             {"emission", rgb_json(m.emission)},
             {"emissivity", m.emissivity},
             {"temperature", std::isfinite(m.temperature) ? nlohmann::json(m.temperature)
                                                          : nlohmann::json(nullptr)}});
    }
    j["materials"] = materials;
    if (scene.camera) {
        const Camera& c = *scene.camera;
        j["camera"] = {{"eye", rgb_json(c.eye)},
                       {"target", rgb_json(c.target)},
                       {"up", rgb_json(c.up)},
                       {"fov_degrees", c.fov_degrees}};
    }
    if (scene.vs3_control) {
        const Vs3Control& v = *scene.vs3_control;
        j["vs3_control"] = {{"eps", v.eps},   {"maxU", v.maxU}, {"maxO", v.maxO}, {"minO", v.minO},
                            {"encl", v.encl}, {"emit", v.emit}, {"row", v.row},   {"col", v.col},
                            {"out", v.out},   {"list", v.list}};
    }
    return j;
}

std::string fmt_vec(const Vec3& v) {
    return fmt::format("({:.6g}, {:.6g}, {:.6g})", v.x(), v.y(), v.z());
}

void print_info(const Scene& scene, const std::vector<std::size_t>& patch_counts, bool all) {
    const nlohmann::json sj = scene_summary_json(scene);
    fmt::print("scene        {}\n", scene.name);
    if (!scene.title.empty()) fmt::print("title        {}\n", scene.title);
    fmt::print("surfaces     {} (+ {} obstruction-only)\n", sj["surfaces"].get<std::size_t>(),
               sj["obstructions"].get<std::size_t>());
    fmt::print("patches      {}", scene.patches.size());
    if (!scene.patches.empty()) {
        fmt::print(" (area min {:.6g}, max {:.6g})", sj["patch_area"]["min"].get<double>(),
                   sj["patch_area"]["max"].get<double>());
    }
    fmt::print("\n");
    fmt::print("total area   {:.10g}\n", sj["total_area"].get<double>());
    Bounds3 b;
    for (const auto& s : scene.surfaces)
        for (const auto& v : s.polygon.vertices) b.extend(v);
    if (!b.empty()) {
        fmt::print("bounds       {} to {}, diagonal {:.6g}\n", fmt_vec(b.lo), fmt_vec(b.hi),
                   b.diagonal().norm());
    }
    fmt::print("enclosure    {}\n", scene.enclosure ? "yes (rows should sum to 1)" : "no");
    fmt::print("closed       {}\n", check_closure(scene).summary());
    fmt::print("materials    {}\n", scene.materials.size());
    for (std::size_t k = 0; k < scene.materials.size(); ++k) {
        const Material& m = scene.materials[k];
        fmt::print("  {:>3}  {:<16} reflectance {}  emission {}  emissivity {:.3g}", k, m.name,
                   fmt_vec(m.reflectance), fmt_vec(m.emission), m.emissivity);
        if (std::isfinite(m.temperature)) fmt::print("  T {:.6g} K", m.temperature);
        fmt::print("\n");
    }
    if (scene.camera) {
        fmt::print("camera       eye {} target {} fov {:.3g}°\n", fmt_vec(scene.camera->eye),
                   fmt_vec(scene.camera->target), scene.camera->fov_degrees);
    }
    const std::size_t limit =
        all ? scene.surfaces.size() : std::min<std::size_t>(40, scene.surfaces.size());
    fmt::print("  {:>4}  {:<20} {:>8} {:>12} {:>8}  {}\n", "#", "surface", "vertices", "area",
               "patches", "material");
    for (std::size_t k = 0; k < limit; ++k) {
        const Surface& s = scene.surfaces[k];
        const std::string mat =
            s.material >= 0 && static_cast<std::size_t>(s.material) < scene.materials.size()
                ? scene.materials[static_cast<std::size_t>(s.material)].name
                : "?";
        fmt::print("  {:>4}  {:<20} {:>8} {:>12.6g} {:>8}  {}{}\n", k, s.name, s.polygon.size(),
                   area(s.polygon), patch_counts[k], mat, s.obstruction ? " (obstruction)" : "");
    }
    if (limit < scene.surfaces.size()) {
        fmt::print("  ... {} more surfaces (--all lists them)\n", scene.surfaces.size() - limit);
    }
    if (!scene.warnings.empty()) {
        fmt::print("warnings     {}\n", scene.warnings.size());
        for (const auto& w : scene.warnings) fmt::print("  {}\n", cli_text(w));
    }
}

void run_info(const InfoArgs& args) {
    args.scene.validate();
    StepTimes times;
    const Scene scene = prepare_scene(args.scene, times);
    std::vector<std::size_t> patch_counts(scene.surfaces.size(), 0);
    for (const auto& p : scene.patches) {
        if (p.surface >= 0 && static_cast<std::size_t>(p.surface) < patch_counts.size())
            ++patch_counts[static_cast<std::size_t>(p.surface)];
    }
    if (args.json) {
        fmt::print("{}", json_text(info_json(scene, patch_counts)));
    } else {
        print_info(scene, patch_counts, args.all);
    }
}

}  // namespace

void add_info_command(CLI::App& app) {
    auto args = std::make_shared<InfoArgs>();
    CLI::App* cmd = app.add_subcommand(
        "info", "Describe a scene: surfaces, obstructions, patches, materials, area, bounds");
    args->scene.add_to(cmd);
    cmd->add_flag("--json", args->json, "Machine-readable output (JSON on standard output)");
    cmd->add_flag("--all", args->all, "List every surface (default: the first 40)");
    cmd->callback([args] { run_info(*args); });
}

}  // namespace formfactor::cli
