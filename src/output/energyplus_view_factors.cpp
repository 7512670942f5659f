#include "formfactor/output/energyplus_view_factors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>
#include <ostream>

#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"

namespace formfactor {

namespace {

constexpr const char* kObject = "ZoneProperty:UserViewFactors:BySurfaceName";

void check(const std::string& zone, const std::vector<std::string>& names, const DenseMatrix& F,
           bool idf) {
    const std::size_t n = names.size();
    if (static_cast<std::size_t>(F.rows()) != n || static_cast<std::size_t>(F.cols()) != n)
        throw Error(fmt::format("{} surface names for a {}×{} matrix", n, F.rows(), F.cols()));
    std::vector<std::string> all = names;
    all.push_back(zone);
    for (const std::string& s : all) {
        if (s.empty()) throw Error(std::string(kObject) + ": an empty zone or surface name");
        if (idf && s.find_first_of(",;!\n\r") != std::string::npos)
            throw Error(
                fmt::format("{}: the name '{}' holds a character IDF cannot carry "
                            "(, ; ! or a line break)",
                            kObject, s));
    }
}

// A field and its `!-` comment aligned as EnergyPlus's own files align them.
void field_line(std::string& out, const std::string& value, bool last, const std::string& note) {
    std::string f = "    " + value + (last ? ";" : ",");
    if (f.size() < 29) f.append(29 - f.size(), ' ');
    out += f + " !- " + note + "\n";
}

}  // namespace

bool energyplus_syntax_for(const std::string& path, EnergyPlusSyntax& syntax) {
    const auto dot = path.find_last_of("./");
    if (dot == std::string::npos || path[dot] != '.') return false;
    std::string ext = path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".idf") {
        syntax = EnergyPlusSyntax::Idf;
        return true;
    }
    if (ext == ".epjson") {
        syntax = EnergyPlusSyntax::EpJson;
        return true;
    }
    return false;
}

namespace {

nlohmann::ordered_json epjson_object(const ZoneViewFactors& z) {
    const std::size_t n = z.names.size();
    nlohmann::ordered_json factors = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t j = 0; j < n; ++j)
            factors.push_back(
                {{"from_surface", z.names[i]},
                 {"to_surface", z.names[j]},
                 {"view_factor", z.F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j))}});
    nlohmann::ordered_json object;
    object["zone_or_zonelist_or_space_or_spacelist_name"] = z.zone;
    object["view_factors"] = std::move(factors);
    return object;
}

}  // namespace

void write_energyplus_view_factors(std::ostream& out, EnergyPlusSyntax syntax,
                                   const std::vector<ZoneViewFactors>& zones) {
    for (std::size_t k = 0; k < zones.size(); ++k) {
        check(zones[k].zone, zones[k].names, zones[k].F, syntax == EnergyPlusSyntax::Idf);
        for (std::size_t m = 0; m < k; ++m)
            if (zones[m].zone == zones[k].zone)
                throw Error(std::string(kObject) + ": zone '" + zones[k].zone + "' appears twice");
    }
    if (syntax == EnergyPlusSyntax::EpJson) {
        nlohmann::ordered_json doc;
        doc[kObject] = nlohmann::ordered_json::object();
        for (const ZoneViewFactors& z : zones)
            doc[kObject][z.zone + " view factors"] = epjson_object(z);
        out << doc.dump(4) << '\n';
        return;
    }
    for (std::size_t k = 0; k < zones.size(); ++k) {
        if (k > 0) out << '\n';
        write_energyplus_view_factors(out, syntax, zones[k].zone, zones[k].names, zones[k].F);
    }
}

void write_energyplus_view_factors(std::ostream& out, EnergyPlusSyntax syntax,
                                   const std::string& zone, const std::vector<std::string>& names,
                                   const DenseMatrix& F) {
    check(zone, names, F, syntax == EnergyPlusSyntax::Idf);
    const std::size_t n = names.size();
    if (syntax == EnergyPlusSyntax::EpJson) {
        write_energyplus_view_factors(out, syntax, {ZoneViewFactors{zone, names, F}});
        return;
    }
    std::string text = fmt::format(
        "! The view factors of zone {} ({} surfaces), from formfactor: row i is what leaves\n"
        "! surface i diffusely and reaches surface j directly.\n\n  {},\n",
        zone, n, kObject);
    field_line(text, zone, n == 0, "Zone or ZoneList or Space or SpaceList Name");
    char number[detail::kMaxNumberChars + 1];
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = 0; j < n; ++j) {
            const std::size_t k = i * n + j + 1;
            field_line(text, names[i], false, fmt::format("From Surface {}", k));
            field_line(text, names[j], false, fmt::format("To Surface {}", k));
            char* end = detail::print_g17(
                number, F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)));
            field_line(text, std::string(number, end), k == n * n,
                       fmt::format("View Factor {}", k));
        }
        if (text.size() >= (std::size_t(1) << 20)) {
            out << text;
            text.clear();
        }
    }
    out << text;
}

void write_energyplus_view_factors(const std::string& path, const std::string& zone,
                                   const std::vector<std::string>& names, const DenseMatrix& F) {
    EnergyPlusSyntax syntax;
    if (!energyplus_syntax_for(path, syntax))
        throw OptionError("output", "'" + path + "' is neither .idf nor .epJSON");
    check(zone, names, F, syntax == EnergyPlusSyntax::Idf);
    write_file_atomically(path, [&](std::ostream& out) {
        write_energyplus_view_factors(out, syntax, zone, names, F);
    });
}

}  // namespace formfactor
