#pragma once
// EnergyPlus's two syntaxes read into one list of objects (the EnergyPlus scene reader builds
// its zones from it; tests read written files back with it).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace formfactor::detail {

/// epJSON documents keep the file's order of objects (surfaces are listed in it).
using EnergyPlusJson = nlohmann::ordered_json;

/// A field of an IDF object, trimmed, with the line it starts on.
struct IdfField {
    std::string value;
    int line = 0;
};

/// One object: its fields by position (IDF) or its JSON body by name (epJSON; `line` is 0).
struct EnergyPlusObject {
    std::string type;                      ///< the class, lower case
    std::string type_as_written;           ///< the class as the file spells it
    std::string name;                      ///< epJSON: the key; IDF: the first field
    int line = 0;                          ///< IDF: where the object starts
    std::vector<IdfField> fields;          ///< IDF: the fields after the class
    const EnergyPlusJson* json = nullptr;  ///< epJSON: the object's body (inside `doc`)
};

/// IDF text: `Class, field, ..., field;` objects, `!` comments to the end of the line. Throws
/// InputError(path, line, ...) for an object not ended by `;` or without a class.
std::vector<EnergyPlusObject> parse_idf(const std::string& text, const std::string& path);

/// epJSON text: {"Class": {"name": {...}, ...}, ...}; `doc` keeps the parsed document the
/// objects point into. Throws InputError(path, 0, ...) for text that is not such JSON.
std::vector<EnergyPlusObject> parse_epjson(const std::string& text, const std::string& path,
                                           EnergyPlusJson& doc);

}  // namespace formfactor::detail
