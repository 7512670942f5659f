// Reading EnergyPlus's IDF and epJSON syntaxes into objects (scene/energyplus_objects.h).

#include "scene/energyplus_objects.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "core/text.h"
#include "formfactor/core/error.h"

namespace formfactor::detail {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

}  // namespace

// ---- IDF ------------------------------------------------------------------------------------

// IDF: `Class, field, field, ...;` with `!` comments to the end of the line. Fields are trimmed;
// commas inside fields do not exist in the format.
std::vector<EnergyPlusObject> parse_idf(const std::string& text, const std::string& path) {
    std::vector<EnergyPlusObject> objects;
    std::vector<IdfField> current;
    std::string field;
    int line = 1, field_line = 0, object_line = 0;
    bool has_content = false;
    auto end_field = [&] {
        current.push_back({trim(field), field_line > 0 ? field_line : line});
        field.clear();
        field_line = 0;
    };
    // A UTF-8 byte order mark (EnergyPlus's editors may write one) is not part of the text.
    const std::size_t start = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
    for (std::size_t k = start; k < text.size(); ++k) {
        const char c = text[k];
        if (c == '!') {
            while (k < text.size() && text[k] != '\n') ++k;
            if (k < text.size()) ++line;
            continue;
        }
        if (c == '\n') {
            ++line;
            field.push_back(' ');
            continue;
        }
        if (c == ',' || c == ';') {
            if (!has_content) object_line = line;
            has_content = true;
            end_field();
            if (c == ';') {
                EnergyPlusObject o;
                o.type_as_written = current.front().value;
                o.type = lower(o.type_as_written);
                o.line = object_line;
                if (o.type.empty())
                    throw InputError(path, object_line, "an object without a class name");
                o.fields.assign(current.begin() + 1, current.end());
                if (!o.fields.empty()) o.name = o.fields.front().value;
                objects.push_back(std::move(o));
                current.clear();
                has_content = false;
            }
            continue;
        }
        if (!std::isspace(static_cast<unsigned char>(c))) {
            if (!has_content) object_line = line;
            has_content = true;
            if (field_line == 0) field_line = line;
        }
        field.push_back(c);
    }
    if (has_content || !trim(field).empty())
        throw InputError(path, object_line,
                         "object '" + (current.empty() ? trim(field) : current.front().value) +
                             "' is not ended by ';'");
    return objects;
}

// ---- epJSON ---------------------------------------------------------------------------------

std::vector<EnergyPlusObject> parse_epjson(const std::string& text, const std::string& path,
                                           EnergyPlusJson& doc) {
    try {
        doc = EnergyPlusJson::parse(text);
    } catch (const nlohmann::json::exception& e) {
        throw InputError(path, 0, std::string("not valid JSON: ") + e.what());
    }
    if (!doc.is_object()) throw InputError(path, 0, "an epJSON file is a JSON object");
    std::vector<EnergyPlusObject> objects;
    for (auto it = doc.begin(); it != doc.end(); ++it) {
        if (!it.value().is_object()) continue;
        for (auto o = it.value().begin(); o != it.value().end(); ++o) {
            if (!o.value().is_object())
                throw InputError(path, 0,
                                 fmt::format("{} '{}' is not a JSON object", it.key(), o.key()));
            EnergyPlusObject ob;
            ob.type_as_written = it.key();
            ob.type = lower(it.key());
            ob.name = o.key();
            ob.json = &o.value();
            objects.push_back(std::move(ob));
        }
    }
    return objects;
}

}  // namespace formfactor::detail
