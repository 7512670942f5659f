#pragma once
// Reading text, for every reader of the library (scene files, point files, matrices, solution
// and property tables): lines, words, fields, and strict numbers. The writers' side is
// core/text_numbers.h.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace formfactor::detail {

/// Reads a whole file into lines (without the line ends; a trailing '\r' is dropped).
/// Throws InputError(path, 0, "cannot open file") (also for a directory), or "cannot read file".
std::vector<std::string> read_lines(const std::string& path);

/// Splits `s` at any of the characters in `separators`; empty words are dropped.
std::vector<std::string> split(std::string_view s, std::string_view separators = " \t");

/// Splits a line of a table at every `separator`, each field trimmed; empty fields are kept
/// ("1,,2" has three fields, "1,2," three, "" one), so that a missing value can be reported.
std::vector<std::string> split_fields(std::string_view line, char separator = ',');

/// `s` without leading and trailing spaces, tabs, '\r' and '\n'.
std::string trim(std::string_view s);

/// Parses a whole word as a double (C locale; "1.", ".5", "1e-3", "+2" accepted; "nan" / "inf"
/// parse and are left to the caller to reject; "+-1", "1x", "" and surrounding spaces do not).
bool parse_double(std::string_view w, double& out);

/// Whether a whole word is a plain decimal number, the form every text reader takes the same
/// way: [sign] digits [. digits] [(e|E) [sign] digits], a digit before or after the point, no
/// nan, inf or hex. (Open Asset Import's readers read other forms differently or throw.)
bool is_plain_decimal(std::string_view w);

/// Parses a whole word as an int ("+3" accepted); false on anything else, overflow included.
bool parse_int(std::string_view w, int& out);

/// Parses a whole word as a size (digits only); false on anything else, overflow included.
bool parse_size(std::string_view w, std::size_t& out);

}  // namespace formfactor::detail
