#include "core/text.h"

#include <charconv>
#include <filesystem>
#include <fstream>

#include "formfactor/core/error.h"

namespace formfactor::detail {

namespace {

// from_chars over the whole word, after one optional '+' (from_chars refuses it) that must not
// be followed by a sign.
template <class T>
bool parse_whole(std::string_view w, T& out) {
    if (!w.empty() && w.front() == '+') {
        w.remove_prefix(1);
        if (!w.empty() && (w.front() == '-' || w.front() == '+')) return false;
    }
    if (w.empty()) return false;
    const char* end = w.data() + w.size();
    const auto [p, ec] = std::from_chars(w.data(), end, out);
    return ec == std::errc() && p == end;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

}  // namespace

std::vector<std::string> read_lines(const std::string& path) {
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

std::vector<std::string> split(std::string_view s, std::string_view separators) {
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

std::vector<std::string> split_fields(std::string_view line, char separator) {
    std::vector<std::string> out;
    std::size_t a = 0;
    while (true) {
        const std::size_t b = line.find(separator, a);
        out.push_back(trim(line.substr(a, b == std::string_view::npos ? b : b - a)));
        if (b == std::string_view::npos) break;
        a = b + 1;
    }
    return out;
}

std::string trim(std::string_view s) {
    std::size_t a = 0, b = s.size();
    while (a < b && is_space(s[a])) ++a;
    while (b > a && is_space(s[b - 1])) --b;
    return std::string(s.substr(a, b - a));
}

bool parse_double(std::string_view w, double& out) { return parse_whole(w, out); }

bool is_plain_decimal(std::string_view w) {
    auto digits = [&w](std::size_t& i) {
        const std::size_t start = i;
        while (i < w.size() && w[i] >= '0' && w[i] <= '9') ++i;
        return i - start;
    };
    std::size_t i = 0;
    if (i < w.size() && (w[i] == '+' || w[i] == '-')) ++i;
    std::size_t mantissa = digits(i);
    if (i < w.size() && w[i] == '.') mantissa += digits(++i);
    if (mantissa == 0) return false;
    if (i < w.size() && (w[i] == 'e' || w[i] == 'E')) {
        ++i;
        if (i < w.size() && (w[i] == '+' || w[i] == '-')) ++i;
        if (digits(i) == 0) return false;
    }
    return i == w.size();
}

bool parse_int(std::string_view w, int& out) { return parse_whole(w, out); }

bool parse_size(std::string_view w, std::size_t& out) {
    if (w.empty() || w.front() == '+') return false;
    return parse_whole(w, out);
}

}  // namespace formfactor::detail
