#pragma once
/// One mechanism for the names of enumerations (methods, samplers, solvers, repair modes): a
/// table of (value, name) entries per enum, the first entry of a value being its name and later
/// ones accepted aliases. The CLI, the reports and the Python module all go through it.
///
///     inline constexpr EnumEntry<RepairMode> kRepairModeNames[] = {
///         {RepairMode::none, "none"}, {RepairMode::reciprocity, "reciprocity"}, ...};
///     RepairMode m = enum_from_name(kRepairModeNames, "closure", "repair", "repair");

#include <cstddef>
#include <string>
#include <string_view>

#include "formfactor/core/error.h"

namespace formfactor {

template <class E>
struct EnumEntry {
    E value;
    const char* name;
};

/// The name of `value` (its first entry); "?" when the table lacks it.
template <class E, std::size_t N>
std::string enum_to_name(const EnumEntry<E> (&table)[N], E value) {
    for (const auto& e : table)
        if (e.value == value) return e.name;
    return "?";
}

/// "a, b, c or d": the names of every value (aliases left out).
template <class E, std::size_t N>
std::string enum_name_list(const EnumEntry<E> (&table)[N]) {
    std::string out;
    std::size_t shown = 0, total = 0;
    for (std::size_t k = 0; k < N; ++k)
        if (enum_to_name(table, table[k].value) == table[k].name) ++total;
    for (std::size_t k = 0; k < N; ++k) {
        if (enum_to_name(table, table[k].value) != table[k].name) continue;  // an alias
        out += shown == 0 ? "" : (shown + 1 == total ? " or " : ", ");
        out += table[k].name;
        ++shown;
    }
    return out;
}

/// The value named `name` (a name or an alias). Throws OptionError(field, "unknown WHAT 'name'
/// (expected a, b, c or d)") otherwise.
template <class E, std::size_t N>
E enum_from_name(const EnumEntry<E> (&table)[N], std::string_view name, const std::string& field,
                 const std::string& what) {
    for (const auto& e : table)
        if (name == e.name) return e.value;
    throw OptionError(field, "unknown " + what + " '" + std::string(name) + "' (expected " +
                                 enum_name_list(table) + ")");
}

}  // namespace formfactor
