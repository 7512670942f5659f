// The OFF check before Open Asset Import (see off_check.h for why).

#include "scene/off_check.h"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "core/text.h"
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
        std::string_view dimension_word;
        std::vector<std::string_view> counts;
        std::size_t l = 0;
        int counts_line = 0;
        for (; l < lines.size() && counts.size() < 3; ++l) {
            for (std::string_view w : words_of(lines[l])) {
                if (counts.size() >= 3) break;
                if (!keyword_seen && counts.empty() && wanted < 0 && is_keyword(w, dimension)) {
                    keyword_seen = true;
                    homogeneous_ = w.find('4') != std::string_view::npos;
                    wanted = dimension ? 1 : 0;
                    continue;
                }
                if (wanted > 0) {
                    dimension_word = w;
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
        // Open Asset Import reads the edges' count whatever stands there: without one it takes
        // the first vertex's first digits for it, and reads every coordinate after in the
        // wrong place. A keyword too: without one, a count that starts with 4 loses its digit
        // (taken for the 4 of 4OFF).
        if (!keyword_seen)
            throw InputError(path_, counts_line,
                             "no OFF keyword before the counts (OFF, COFF, NOFF, STOFF, 4OFF or "
                             "nOFF): without one the header is misread");
        if (counts.size() < 3 || line_of(bytes, counts[2].data()) != counts_line)
            throw InputError(path_, counts_line,
                             "the header has no count of edges after those of vertices and faces "
                             "(write 0): without it the first vertex is misread");
        count(counts[2], "edges", counts_line);
        dimensions_ = 3;
        if (dimension) {
            dimensions_ = static_cast<int>(count(dimension_word, "dimensions", counts_line));
            if (dimensions_ < 1 || dimensions_ > 3)
                throw InputError(path_, counts_line,
                                 "the vertices have " + std::to_string(dimensions_) +
                                     " coordinates; 1 to 3 can be read");
        }
        check_data(bytes, counts[2].data() + counts[2].size(), counts_line, vertices, faces);
    }

  private:
    // The line (from 1) of a position in the file.
    static int line_of(const std::string& bytes, const char* at) {
        return 1 + static_cast<int>(std::count(bytes.data(), at, '\n'));
    }

    // The vertex and face lines, read as Open Asset Import 5.2.5 reads them: from the first
    // word after the counts (blank space and comment lines skipped), one line per vertex, then
    // one per face, where a line is what lies between line ends ('\n', '\r', '\f'; a run of
    // them is one), in words parted by spaces and tabs. Each must be what that reader takes it
    // for, since it reads a blank or comment line as a vertex at the origin, a word that is not
    // a number as 0 (or as its leading digits), drops faces of 0 or more than 9 vertices, puts
    // an index past the vertices on the last one, copies a line into 4,096 bytes, and stops at
    // a NUL byte.
    void check_data(const std::string& bytes, const char* after_counts, int counts_line,
                    long long vertices, long long faces) const {
        const char* p = after_counts;
        const char* const end = bytes.data() + bytes.size();
        const char* counted = bytes.data();  // line numbers counted up to here
        int line_number = 1;
        auto line_at = [&](const char* at) {
            line_number += static_cast<int>(std::count(counted, at, '\n'));
            counted = at;
            return line_number;
        };
        auto is_line_end = [](char c) { return c == '\n' || c == '\r' || c == '\f'; };
        // Blank space and comment lines up to the first vertex.
        for (;;) {
            while (p < end && (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\n')) ++p;
            if (p < end && *p == '#') {
                while (p < end && *p != '\n') ++p;
                continue;
            }
            break;
        }
        const int vertex_words = dimensions_ + (homogeneous_ ? 1 : 0);
        for (long long k = 0; k < vertices + faces; ++k) {
            const bool is_vertex = k < vertices;
            const long long index = is_vertex ? k : k - vertices;
            const int line = line_at(p);
            const char* start = p;
            while (p < end && !is_line_end(*p) && *p != '\0') ++p;
            if (p == start && (p == end || *p == '\0'))
                throw InputError(path_, counts_line,
                                 "the header declares " + std::to_string(vertices) +
                                     " vertices and " + std::to_string(faces) +
                                     " faces, but only " + std::to_string(k) +
                                     " lines of data follow");
            const std::string_view text(start, static_cast<std::size_t>(p - start));
            if (text.size() >= 4095)
                throw InputError(path_, line,
                                 "a line of " + std::to_string(text.size()) +
                                     " bytes; lines of vertices and faces must be shorter than "
                                     "4,095 bytes");
            if (p < end && *p == '\0')
                throw InputError(path_, line, "a NUL byte: an OFF file is text");
            while (p < end && is_line_end(*p)) ++p;
            const std::vector<std::string_view> words = line_words(text);
            if (words.empty())
                throw InputError(path_, line,
                                 std::string("a blank or comment line where ") +
                                     (is_vertex ? "vertex " : "face ") + std::to_string(index + 1) +
                                     " of " + std::to_string(is_vertex ? vertices : faces) +
                                     " should be (it would be read as one)");
            if (is_vertex) {
                if (static_cast<int>(words.size()) < vertex_words)
                    throw InputError(path_, line,
                                     "vertex " + std::to_string(index + 1) + " has " +
                                         std::to_string(words.size()) + " of its " +
                                         std::to_string(vertex_words) + " coordinates");
                for (int c = 0; c < vertex_words; ++c)
                    if (!is_plain_decimal(words[c]))
                        throw InputError(path_, line,
                                         "vertex " + std::to_string(index + 1) + ": '" +
                                             shown(words[c]) + "' is not a number");
                continue;
            }
            if (words.empty() || !is_whole(words[0]))
                throw InputError(path_, line,
                                 "face " + std::to_string(index + 1) +
                                     ": expected its number of vertices, got '" +
                                     (words.empty() ? std::string() : shown(words[0])) + "'");
            const long long n = whole(words[0]);
            if (n < 1 || n > 9)
                throw InputError(path_, line,
                                 "face " + std::to_string(index + 1) + " has " +
                                     std::string(shown(words[0])) +
                                     " vertices; faces of 1 to 9 vertices can be read (split "
                                     "larger ones)");
            if (static_cast<long long>(words.size()) < n + 1)
                throw InputError(path_, line,
                                 "face " + std::to_string(index + 1) + " has " +
                                     std::to_string(words.size() - 1) + " of its " +
                                     std::to_string(n) + " vertex indices");
            for (long long m = 1; m <= n; ++m) {
                const std::string_view w = words[static_cast<std::size_t>(m)];
                if (!is_whole(w) || whole(w) >= vertices)
                    throw InputError(path_, line,
                                     "face " + std::to_string(index + 1) + ": vertex index '" +
                                         shown(w) + "' is not one of 0 to " +
                                         std::to_string(vertices - 1));
            }
        }
    }

    // The words of a vertex or face line: parted by spaces and tabs, up to a comment.
    static std::vector<std::string_view> line_words(std::string_view line) {
        std::vector<std::string_view> words;
        std::size_t i = 0;
        while (i < line.size()) {
            while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
            if (i < line.size() && line[i] == '#') break;
            const std::size_t start = i;
            while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
            if (i > start) words.push_back(line.substr(start, i - start));
        }
        return words;
    }

    static bool is_whole(std::string_view w) {
        if (w.empty() || w.size() > 10) return false;
        for (char c : w)
            if (c < '0' || c > '9') return false;
        return true;
    }

    static long long whole(std::string_view w) {
        long long v = 0;
        for (char c : w) v = 10 * v + (c - '0');
        return v;
    }

    // A word as a message shows it: at most 32 bytes, control bytes as '?'.
    static std::string shown(std::string_view w) {
        std::string s(w.substr(0, 32));
        for (char& c : s)
            if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
        return s;
    }

    // A count: a whole number below 2³¹.
    long long count(std::string_view w, const char* what, int line) const {
        if (!is_whole(w) || whole(w) > 2147483647LL)
            throw InputError(path_, line,
                             std::string("the count of ") + what + " '" + shown(w) +
                                 "' is not a whole number below 2^31");
        return whole(w);
    }

    std::string path_;
    bool homogeneous_ = false;
    int dimensions_ = 3;
};

}  // namespace

void check_off(const std::string& path) { OffCheck(path).run(); }

}  // namespace formfactor::detail
