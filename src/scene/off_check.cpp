// The OFF check before Open Asset Import (see off_check.h for why).

#include "scene/off_check.h"

#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "formfactor/core/error.h"

namespace formfactor::detail {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// The words of a line up to a comment.
std::vector<std::string_view> words_of(std::string_view line) {
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    std::vector<std::string_view> words;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        const std::size_t start = i;
        while (i < line.size() && !is_space(line[i])) ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
    return words;
}

// The keyword of the OFF variants: [ST][C][N][4][n]OFF. `dimension` is set when it has `n`.
bool is_keyword(std::string_view w, bool& dimension) {
    if (w.size() < 3 || w.substr(w.size() - 3) != "OFF") return false;
    std::string_view p = w.substr(0, w.size() - 3);
    auto take = [&p](std::string_view prefix) {
        if (p.substr(0, prefix.size()) != prefix) return false;
        p.remove_prefix(prefix.size());
        return true;
    };
    take("ST");
    take("C");
    take("N");
    take("4");
    dimension = take("n");
    return p.empty();
}

class OffCheck {
  public:
    explicit OffCheck(std::string path) : path_(std::move(path)) {}

    void run() {
        std::ifstream in(path_, std::ios::binary);
        if (!in) throw InputError(path_, 0, "cannot open file");
        const std::string bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
        if (in.bad()) throw InputError(path_, 0, "cannot read file");
        std::vector<std::string_view> lines;
        for (std::size_t pos = 0; pos < bytes.size();) {
            std::size_t end = bytes.find('\n', pos);
            if (end == std::string::npos) end = bytes.size();
            lines.emplace_back(bytes.data() + pos, end - pos);
            pos = end + 1;
        }
        // The header's words in order, with the line each stands on, up to the counts.
        bool keyword_seen = false, dimension = false;
        int wanted = -1;  // words still wanted before the counts: the dimension
        std::vector<std::string_view> counts;
        std::size_t l = 0;
        int counts_line = 0;
        for (; l < lines.size() && counts.size() < 2; ++l) {
            for (std::string_view w : words_of(lines[l])) {
                if (counts.size() >= 2) break;
                if (!keyword_seen && counts.empty() && wanted < 0 && is_keyword(w, dimension)) {
                    keyword_seen = true;
                    wanted = dimension ? 1 : 0;
                    continue;
                }
                if (wanted > 0) {
                    --wanted;
                    continue;
                }
                wanted = 0;
                if (counts.empty()) counts_line = static_cast<int>(l) + 1;
                counts.push_back(w);
            }
        }
        if (counts.size() < 2)
            throw InputError(path_, 0,
                             "not an OFF file: no counts of vertices and faces in its header");
        const long long vertices = count(counts[0], "vertices", counts_line);
        const long long faces = count(counts[1], "faces", counts_line);
        if (vertices == 0) throw InputError(path_, counts_line, "the header declares no vertices");
        if (faces == 0) throw InputError(path_, counts_line, "the header declares no faces");
        long long left = 0;
        for (; l < lines.size(); ++l)
            if (!words_of(lines[l]).empty()) ++left;
        if (vertices + faces > left)
            throw InputError(path_, counts_line,
                             "the header declares " + std::to_string(vertices) + " vertices and " +
                                 std::to_string(faces) + " faces, but only " +
                                 std::to_string(left) + " lines of data follow");
    }

  private:
    // A count: a whole number below 2³¹.
    long long count(std::string_view w, const char* what, int line) const {
        long long v = 0;
        bool ok = !w.empty() && w.size() <= 10;
        for (char c : w) {
            if (c < '0' || c > '9') ok = false;
            if (ok) v = 10 * v + (c - '0');
        }
        if (!ok || v > 2147483647LL) {
            std::string shown(w.substr(0, 32));
            for (char& c : shown)
                if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
            throw InputError(path_, line,
                             std::string("the count of ") + what + " '" + shown +
                                 "' is not a whole number below 2^31");
        }
        return v;
    }

    std::string path_;
};

}  // namespace

void check_off(const std::string& path) { OffCheck(path).run(); }

}  // namespace formfactor::detail
