#include "formfactor/solve/properties.h"

#include <fmt/format.h>

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "core/text.h"
#include "formfactor/core/error.h"

namespace formfactor {

PatchProperties properties_from_scene(const Scene& scene) {
    PatchProperties p;
    const std::size_t n = scene.patches.size();
    p.reflectance.resize(n);
    p.emission.resize(n);
    p.emissivity.resize(n);
    p.temperature.resize(n);
    p.net_flux.assign(n, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t i = 0; i < n; ++i) {
        const int s = scene.patches[i].surface;
        if (s < 0 || static_cast<std::size_t>(s) >= scene.surfaces.size())
            throw GeometryError(
                fmt::format("patch {} names surface {}, which does not exist", i, s));
        const int m = scene.surfaces[static_cast<std::size_t>(s)].material;
        Material mat;  // defaults when the scene has no material table
        if (!scene.materials.empty()) {
            if (m < 0 || static_cast<std::size_t>(m) >= scene.materials.size())
                throw GeometryError(
                    fmt::format("surface {} names material {}, which does not exist", s, m));
            mat = scene.materials[static_cast<std::size_t>(m)];
        }
        p.reflectance[i] = mat.reflectance;
        p.emission[i] = mat.emission;
        p.emissivity[i] = mat.emissivity;
        p.temperature[i] = mat.temperature;
    }
    return p;
}

namespace {

enum Column {
    kRefR,
    kRefG,
    kRefB,
    kEmiR,
    kEmiG,
    kEmiB,
    kEmissivity,
    kTemperature,
    kNetFlux,
    kColumns
};
constexpr std::array<const char*, kColumns> kColumnNames = {
    "reflectance_r", "reflectance_g", "reflectance_b", "emission_r", "emission_g",
    "emission_b",    "emissivity",    "temperature",   "net_flux"};

// Splits a CSV line on commas; cells may be double-quoted (surface names with commas).
std::vector<std::string> split_csv(const std::string& line) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (std::size_t k = 0; k < line.size(); ++k) {
        const char ch = line[k];
        if (quoted) {
            if (ch == '"' && k + 1 < line.size() && line[k + 1] == '"') {
                cell += '"';
                ++k;
            } else if (ch == '"') {
                quoted = false;
            } else {
                cell += ch;
            }
        } else if (ch == '"') {
            quoted = true;
        } else if (ch == ',') {
            cells.push_back(detail::trim(cell));
            cell.clear();
        } else {
            cell += ch;
        }
    }
    cells.push_back(detail::trim(cell));
    return cells;
}

std::optional<double> parse_number(const std::string& s) {
    double v = 0.0;
    if (!detail::parse_double(s, v) || !std::isfinite(v)) return std::nullopt;
    return v;
}

std::string check_value(int column, double v) {
    switch (column) {
        case kRefR:
        case kRefG:
        case kRefB:
            if (!(v >= 0.0 && v < 1.0)) return "must be in [0, 1)";
            break;
        case kEmiR:
        case kEmiG:
        case kEmiB:
            if (!(v >= 0.0)) return "must be ≥ 0";
            break;
        case kEmissivity:
            if (!(v > 0.0 && v <= 1.0)) return "must be in (0, 1]";
            break;
        case kTemperature:
            if (!(v >= 0.0)) return "must be ≥ 0 K";
            break;
        default:
            break;
    }
    return {};
}

}  // namespace

void apply_properties_csv(const std::string& path, const Scene& scene, PatchProperties& props) {
    std::ifstream in(path);
    if (!in) throw InputError(path, 0, "cannot open the properties file");
    apply_properties_csv(in, path, scene, props);
}

void apply_properties_csv(std::istream& in, const std::string& path, const Scene& scene,
                          PatchProperties& props) {
    const std::size_t n = props.size();
    std::string line;
    int line_no = 0;
    std::vector<int> column_of;  // cell index → Column, or -1 for the key
    int ncells = 0;
    bool by_surface = false;
    bool have_header = false;
    std::map<std::string, std::vector<std::size_t>> surface_patches;
    for (std::size_t i = 0; i < scene.patches.size(); ++i) {
        const int s = scene.patches[i].surface;
        if (s >= 0 && static_cast<std::size_t>(s) < scene.surfaces.size())
            surface_patches[scene.surfaces[static_cast<std::size_t>(s)].name].push_back(i);
    }
    while (std::getline(in, line)) {
        ++line_no;
        const std::string t = detail::trim(line);
        if (t.empty() || t[0] == '#') continue;
        const auto cells = split_csv(line);
        if (!have_header) {
            have_header = true;
            ncells = static_cast<int>(cells.size());
            int keys = 0;
            std::array<bool, kColumns> seen{};
            for (const auto& name : cells) {
                if (name == "patch" || name == "surface") {
                    ++keys;
                    by_surface = name == "surface";
                    column_of.push_back(-1);
                    continue;
                }
                int col = -1;
                for (int c = 0; c < kColumns; ++c)
                    if (name == kColumnNames[static_cast<std::size_t>(c)]) col = c;
                if (col < 0)
                    throw InputError(path, line_no,
                                     "unknown column '" + name +
                                         "' (expected patch or surface, then any of "
                                         "reflectance_r,reflectance_g,reflectance_b,emission_r,"
                                         "emission_g,emission_b,emissivity,temperature,net_flux)");
                if (seen[static_cast<std::size_t>(col)])
                    throw InputError(path, line_no, "column '" + name + "' appears twice");
                seen[static_cast<std::size_t>(col)] = true;
                column_of.push_back(col);
            }
            if (keys != 1)
                throw InputError(path, line_no,
                                 "the header needs exactly one key column: patch or surface");
            continue;
        }
        if (static_cast<int>(cells.size()) != ncells)
            throw InputError(path, line_no,
                             fmt::format("{} cells, the header has {}", cells.size(), ncells));
        std::vector<std::size_t> targets;
        std::array<std::optional<double>, kColumns> values;
        for (int k = 0; k < ncells; ++k) {
            const std::string& cell = cells[static_cast<std::size_t>(k)];
            const int col = column_of[static_cast<std::size_t>(k)];
            if (col < 0) {
                if (by_surface) {
                    const auto it = surface_patches.find(cell);
                    if (it == surface_patches.end())
                        throw InputError(path, line_no, "unknown surface '" + cell + "'");
                    targets = it->second;
                } else {
                    const auto v = parse_number(cell);
                    if (!v || *v != std::floor(*v))
                        throw InputError(path, line_no,
                                         "patch index '" + cell + "' is not an integer");
                    if (*v < 0 || *v >= static_cast<double>(n))
                        throw InputError(path, line_no,
                                         fmt::format("patch index {} out of range (the scene "
                                                     "has {} patches: 0..{})",
                                                     cell, n, n == 0 ? 0 : n - 1));
                    targets = {static_cast<std::size_t>(*v)};
                }
                continue;
            }
            if (cell.empty()) continue;
            const auto v = parse_number(cell);
            const char* cname = kColumnNames[static_cast<std::size_t>(col)];
            if (!v)
                throw InputError(path, line_no, fmt::format("{}: bad number '{}'", cname, cell));
            const std::string why = check_value(col, *v);
            if (!why.empty())
                throw InputError(path, line_no, fmt::format("{} = {} {}", cname, cell, why));
            values[static_cast<std::size_t>(col)] = v;
        }
        if (values[kTemperature] && values[kNetFlux])
            throw InputError(path, line_no,
                             "give either temperature or net_flux for a patch, not both");
        for (std::size_t i : targets) {
            for (int c = 0; c < 3; ++c) {
                if (values[static_cast<std::size_t>(kRefR + c)])
                    props.reflectance[i][c] = *values[static_cast<std::size_t>(kRefR + c)];
                if (values[static_cast<std::size_t>(kEmiR + c)])
                    props.emission[i][c] = *values[static_cast<std::size_t>(kEmiR + c)];
            }
            if (values[kEmissivity]) props.emissivity[i] = *values[kEmissivity];
            if (values[kTemperature]) {
                props.temperature[i] = *values[kTemperature];
                props.net_flux[i] = std::numeric_limits<double>::quiet_NaN();
            }
            if (values[kNetFlux]) {
                props.net_flux[i] = *values[kNetFlux];
                props.temperature[i] = std::numeric_limits<double>::quiet_NaN();
            }
        }
    }
    if (!have_header) throw InputError(path, 0, "empty properties file (no header row)");
}

void validate_properties(const PatchProperties& p) {
    const std::size_t n = p.size();
    if (p.emission.size() != n || p.emissivity.size() != n || p.temperature.size() != n ||
        p.net_flux.size() != n)
        throw GeometryError("properties: the per-patch arrays differ in length");
    for (std::size_t i = 0; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            if (!(p.reflectance[i][c] >= 0.0 && p.reflectance[i][c] < 1.0))
                throw GeometryError(
                    fmt::format("patch {}: reflectance {} outside [0, 1)", i, p.reflectance[i][c]));
            if (!(p.emission[i][c] >= 0.0) || !std::isfinite(p.emission[i][c]))
                throw GeometryError(
                    fmt::format("patch {}: emission {} is not ≥ 0", i, p.emission[i][c]));
        }
        if (!(p.emissivity[i] > 0.0 && p.emissivity[i] <= 1.0))
            throw GeometryError(
                fmt::format("patch {}: emissivity {} outside (0, 1]", i, p.emissivity[i]));
        if (!std::isnan(p.temperature[i]) &&
            !(p.temperature[i] >= 0.0 && std::isfinite(p.temperature[i])))
            throw GeometryError(
                fmt::format("patch {}: temperature {} K is negative", i, p.temperature[i]));
        if (!std::isnan(p.temperature[i]) && !std::isnan(p.net_flux[i]))
            throw GeometryError(
                fmt::format("patch {}: both a temperature and a net flux are prescribed", i));
    }
}

}  // namespace formfactor
