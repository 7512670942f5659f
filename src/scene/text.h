#pragma once
// Private helpers of the scene loaders and writers: reading lines, splitting words, strict
// number parsing and atomic file writing.

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"

namespace formfactor::detail {

/// Reads a whole file into lines (without the line ends; a trailing '\r' is dropped).
/// Throws InputError(path, 0, "cannot open file").
inline std::vector<std::string> read_lines(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in || std::filesystem::is_directory(path)) throw InputError(path, 0, "cannot open file");
    std::vector<std::string> lines;
    std::string line;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(std::move(line));
    }
    if (in.bad()) throw InputError(path, 0, "cannot read file");
    return lines;
}

/// Splits `s` at any of the characters in `separators` (empty words are dropped).
inline std::vector<std::string> split(std::string_view s, std::string_view separators = " \t") {
    std::vector<std::string> out;
    std::size_t k = 0;
    while (k < s.size()) {
        while (k < s.size() && separators.find(s[k]) != std::string_view::npos) ++k;
        std::size_t e = k;
        while (e < s.size() && separators.find(s[e]) == std::string_view::npos) ++e;
        if (e > k) out.emplace_back(s.substr(k, e - k));
        k = e;
    }
    return out;
}

inline std::string trim(std::string_view s) {
    std::size_t a = 0, b = s.size();
    while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\r' || s[a] == '\n')) ++a;
    while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r' || s[b - 1] == '\n'))
        --b;
    return std::string(s.substr(a, b - a));
}

/// Parses a whole word as a double (C locale; "1.", ".5", "1e-3", "+2" accepted; "nan"/"inf"
/// parse and are left to the caller to reject). False on anything else.
inline bool parse_double(std::string_view w, double& out) {
    if (w.empty()) return false;
    if (w.front() == '+') w.remove_prefix(1);
    const char* end = w.data() + w.size();
    auto [p, ec] = std::from_chars(w.data(), end, out);
    return ec == std::errc() && p == end;
}

/// Parses a whole word as an int. False on anything else (including overflow).
inline bool parse_int(std::string_view w, int& out) {
    if (w.empty()) return false;
    if (w.front() == '+') w.remove_prefix(1);
    const char* end = w.data() + w.size();
    auto [p, ec] = std::from_chars(w.data(), end, out);
    return ec == std::errc() && p == end;
}

/// Formats a double with 17 significant digits (exact round trip), shortest when possible.
inline std::string exact(double x) {
    char buf[64];
    auto [p, ec] = std::to_chars(buf, buf + sizeof buf, x);
    return ec == std::errc() ? std::string(buf, p) : std::string("nan");
}

/// Writes `text` to `path` atomically: to `path + ".tmp"`, then rename.
inline void write_atomically(const std::string& path, const std::string& text) {
    const std::string tmp = path + ".tmp";
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw InputError(path, 0, "cannot write file");
        out << text;
        out.flush();
        if (!out) {
            out.close();
            std::error_code ec;
            std::filesystem::remove(tmp, ec);
            throw InputError(path, 0, "cannot write file");
        }
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        throw InputError(path, 0, "cannot write file (rename failed)");
    }
}

/// Throws InputError(path, 0, ...) when the scene read from `path` has no surface with a row
/// (no faces at all, or only obstruction-only ones): there is nothing to compute. `none`: what
/// the format lacks ("no faces (f records)"); `hint`: which of its surfaces have rows.
inline void require_surfaces(const Scene& scene, const std::string& path, const std::string& none,
                             const std::string& hint) {
    std::size_t obstructions = 0;
    for (const Surface& s : scene.surfaces) obstructions += s.obstruction ? 1 : 0;
    if (scene.surfaces.size() > obstructions) return;
    if (scene.surfaces.empty())
        throw InputError(path, 0, "the scene is empty: " + none + ", nothing to compute");
    throw InputError(path, 0,
                     "all " + std::to_string(obstructions) +
                         " surfaces are obstructions: there are no surfaces to compute form "
                         "factors between (" +
                         hint + ")");
}

/// A short form of a number for messages ("2.1e-03").
inline std::string short_number(double x) {
    std::ostringstream s;
    s.precision(2);
    s << x;
    return s.str();
}

}  // namespace formfactor::detail
