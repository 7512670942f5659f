// --all-zones: the zones of an EnergyPlus model and their file names (all_zones.h).

#include "all_zones.h"

#include <fmt/format.h>

#include <cctype>
#include <filesystem>

#include "formfactor/core/error.h"
#include "formfactor/output/energyplus_view_factors.h"
#include "formfactor/scene/energyplus.h"

namespace formfactor::cli {

std::string file_name_part(const std::string& zone) {
    std::string part = zone;
    for (char& c : part) {
        const auto u = static_cast<unsigned char>(c);
        if (!(std::isalnum(u) || c == '-' || c == '_' || u >= 0x80)) c = '_';
    }
    return part;
}

std::string zone_file(const std::string& path, const std::string& zone) {
    const std::string part = file_name_part(zone);
    static const std::string kPlaceholder = "{zone}";
    if (path.find(kPlaceholder) != std::string::npos) {
        std::string out = path;
        for (std::size_t at = 0; (at = out.find(kPlaceholder, at)) != std::string::npos;
             at += part.size())
            out.replace(at, kPlaceholder.size(), part);
        return out;
    }
    const std::filesystem::path p(path);
    return (p.parent_path() / (p.stem().string() + "_" + part + p.extension().string())).string();
}

std::vector<std::string> all_zones(const SceneArgs& scene, const std::string& does) {
    EnergyPlusSyntax syntax = EnergyPlusSyntax::Idf;
    if (!energyplus_syntax_for(scene.scene, syntax))
        throw OptionError("--all-zones", does +
                                             " the zones of an EnergyPlus model (.idf or "
                                             ".epJSON); '" +
                                             scene.scene + "' is not one");
    if (!scene.zone.empty())
        throw OptionError("--all-zones", does + " every zone: leave out --zone");
    const std::vector<std::string> zones = energyplus_zones(scene.scene);
    if (zones.empty()) throw InputError(scene.scene, 0, "no Zone objects (nothing to enclose)");
    return zones;
}

void ZoneOutputs::claim(std::string& path, const std::string& zone) {
    if (path.empty()) return;
    path = zone_file(path, zone);
    const std::string key = std::filesystem::path(path).lexically_normal().string();
    const auto [it, fresh] = zone_of_file_.emplace(key, zone);
    if (!fresh)
        throw OptionError("--all-zones",
                          fmt::format("zones '{}' and '{}' would both write '{}'; put "
                                      "{{zone}} where the name goes or compute them "
                                      "one by one with --zone",
                                      it->second, zone, path));
}

void finish(OutputTransaction& tx, OutputTransaction* outer) {
    if (outer)
        outer->adopt(tx);
    else
        tx.commit();
}

void print_wrote(const std::string& files, const OutputTransaction* outer) {
    fmt::print("{:<10} {}\n", outer ? "output" : "wrote", files);
}

}  // namespace formfactor::cli
