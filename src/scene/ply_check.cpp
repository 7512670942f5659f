// The PLY check before Open Asset Import (see ply_check.h for why). The grammar is the one of
// Greg Turk's PLY description, as the common writers (rply, Blender, MeshLab, trimesh) write
// it: `ply`, then `format`, then `element` / `property` / `comment` / `obj_info` lines, then
// `end_header`; ASCII data holds one element instance per line.

#include "scene/ply_check.h"

#include <charconv>
#include <climits>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/text.h"
#include "formfactor/core/error.h"

namespace formfactor::detail {

namespace {

enum class Kind { integer, unsigned_integer, real };

struct Type {
    const char* name;
    int bytes;
    Kind kind;
};

// The PLY types under both of their names.
constexpr Type kTypes[] = {
    {"char", 1, Kind::integer},
    {"int8", 1, Kind::integer},
    {"uchar", 1, Kind::unsigned_integer},
    {"uint8", 1, Kind::unsigned_integer},
    {"short", 2, Kind::integer},
    {"int16", 2, Kind::integer},
    {"ushort", 2, Kind::unsigned_integer},
    {"uint16", 2, Kind::unsigned_integer},
    {"int", 4, Kind::integer},
    {"int32", 4, Kind::integer},
    {"uint", 4, Kind::unsigned_integer},
    {"uint32", 4, Kind::unsigned_integer},
    {"float", 4, Kind::real},
    {"float32", 4, Kind::real},
    {"double", 8, Kind::real},
    {"float64", 8, Kind::real},
};

const Type* find_type(std::string_view name) {
    for (const Type& t : kTypes)
        if (name == t.name) return &t;
    return nullptr;
}

struct Property {
    std::string name;
    const Type* type = nullptr;
    const Type* count_type = nullptr;  // a list's count; null for a single value
};

struct Element {
    std::string name;
    long long count = 0;
    int line = 0;
    std::vector<Property> properties;
};

enum class Format { ascii, little_endian, big_endian };

bool is_digits(std::string_view w) {
    if (w.empty()) return false;
    for (char c : w)
        if (c < '0' || c > '9') return false;
    return true;
}

// A number as Open Asset Import's text parsers read it whole: [-]digits for the integer types
// (its unsigned parser stops at a sign), a plain decimal for the real ones (no nan, inf or hex,
// which it reads differently or throws on).
bool word_fits(std::string_view w, const Type& t, long long* value = nullptr) {
    if (t.kind != Kind::real) {
        const bool negative = !w.empty() && w.front() == '-';
        if (!is_digits(negative ? w.substr(1) : w)) return false;
        long long v = 0;
        const auto [p, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
        if (ec != std::errc() || p != w.data() + w.size()) return false;
        const int bits = 8 * t.bytes;
        const long long lo = t.kind == Kind::integer ? -(1LL << (bits - 1)) : 0;
        const long long hi = t.kind == Kind::integer ? (1LL << (bits - 1)) - 1 : (1LL << bits) - 1;
        if (v < lo || v > hi) return false;
        if (value != nullptr) *value = v;
        return true;
    }
    double d = 0;
    return is_plain_decimal(w) && parse_double(w, d);
}

std::string type_list() {
    return "char, uchar, short, ushort, int, uint, float, double, or int8, uint8, int16, uint16, "
           "int32, uint32, float32, float64";
}

class PlyCheck {
  public:
    explicit PlyCheck(std::string path) : path_(std::move(path)) {}

    void run() {
        std::ifstream in(path_, std::ios::binary);
        if (!in) throw InputError(path_, 0, "cannot open file");
        bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (in.bad()) throw InputError(path_, 0, "cannot read file");
        header();
        if (format_ == Format::ascii)
            ascii_data();
        else
            binary_data();
    }

  private:
    // Control bytes of a damaged file quoted in `msg` are shown as '?'.
    [[noreturn]] void fail(int line, std::string msg) const {
        for (char& c : msg)
            if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
        throw InputError(path_, line, msg);
    }

    // The next line from pos_ (without '\n' or a trailing '\r'); false at the end of the file.
    bool next_line(std::string_view& line) {
        if (pos_ >= bytes_.size()) return false;
        const std::size_t end = bytes_.find('\n', pos_);
        const std::size_t stop = end == std::string::npos ? bytes_.size() : end;
        line = std::string_view(bytes_).substr(pos_, stop - pos_);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos_ = end == std::string::npos ? bytes_.size() : end + 1;
        ++line_;
        return true;
    }

    void header() {
        std::string_view line;
        if (!next_line(line) || trim(line) != "ply")
            fail(1, "not a PLY file: the first line is not 'ply'");
        if (!next_line(line)) fail(0, "the header ends after 'ply': no format line");
        const std::vector<std::string> f = split(line);
        if (f.size() != 3 || f[0] != "format")
            fail(line_, "expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian)");
        if (f[1] == "ascii")
            format_ = Format::ascii;
        else if (f[1] == "binary_little_endian")
            format_ = Format::little_endian;
        else if (f[1] == "binary_big_endian")
            format_ = Format::big_endian;
        else
            fail(line_, "unknown format '" + f[1] +
                            "' (ascii, binary_little_endian or binary_big_endian)");
        if (f[2] != "1.0") fail(line_, "PLY version '" + f[2] + "' (only 1.0 is known)");
        while (true) {
            if (!next_line(line))
                fail(0, "the header never ends: no 'end_header' line (" + std::to_string(line_) +
                            " lines read)");
            for (char c : line)
                if (static_cast<unsigned char>(c) < 0x20 && c != '\t')
                    fail(line_,
                         "the header holds a control character: is the file cut short "
                         "or damaged?");
            const std::vector<std::string> w = split(line);
            if (w.empty()) fail(line_, "empty line in the header");
            if (w[0] == "comment" || w[0] == "obj_info") continue;
            if (w[0] == "end_header") {
                if (w.size() != 1) fail(line_, "'end_header' followed by more on its line");
                break;
            }
            if (w[0] == "element")
                element(w);
            else if (w[0] == "property")
                property(w);
            else
                fail(line_, "'" + w[0] +
                                "' is not a header line of PLY (element, property, comment, "
                                "obj_info, end_header)");
        }
        for (const Element& e : elements_) semantics(e);
        elements_assimp_skips();
    }

    // Open Asset Import knows these elements by name. For any other it takes the count from
    // the first digits after `element` (those of the name, or none: 0), so it reads no data for
    // an element like `camera 1` and would read 2^32 - 1 instances of one named `4294967295`.
    // Such an element is harmless after the ones it reads, where its data is left unread.
    static bool known_to_assimp(const std::string& name) {
        return name == "vertex" || name == "face" || name == "tristrips" || name == "edge" ||
               name == "material";
    }

    void elements_assimp_skips() const {
        for (std::size_t k = 0; k < elements_.size(); ++k) {
            const Element& e = elements_[k];
            if (known_to_assimp(e.name)) continue;
            if (e.name[0] >= '0' && e.name[0] <= '9')
                fail(e.line, "element '" + e.name +
                                 "': a name that starts with a digit (Open Asset Import reads "
                                 "it as the element's count)");
            if (e.count == 0) continue;
            for (std::size_t j = k + 1; j < elements_.size(); ++j)
                if (known_to_assimp(elements_[j].name))
                    fail(e.line, "element '" + e.name + "' (" + std::to_string(e.count) +
                                     ") comes before element '" + elements_[j].name +
                                     "': Open Asset Import skips the data of elements other "
                                     "than vertex, face, tristrips, edge and material, and "
                                     "would misread what follows; move it after them");
        }
    }

    void element(const std::vector<std::string>& w) {
        if (w.size() != 3) fail(line_, "expected 'element NAME COUNT'");
        std::size_t n = 0;
        if (!parse_size(w[2], n) || n > static_cast<std::size_t>(INT_MAX))
            fail(line_, "element '" + w[1] + "': count '" + w[2] +
                            "' is not a whole number up to 2147483647");
        for (const Element& e : elements_)
            if (e.name == w[1])
                fail(line_, "element '" + w[1] + "' declared twice (first at line " +
                                std::to_string(e.line) + ")");
        elements_.push_back(Element{w[1], static_cast<long long>(n), line_, {}});
    }

    void property(const std::vector<std::string>& w) {
        if (elements_.empty()) fail(line_, "a property before any element");
        Element& e = elements_.back();
        Property p;
        if (w.size() >= 2 && w[1] == "list") {
            if (w.size() != 5) fail(line_, "expected 'property list COUNT_TYPE TYPE NAME'");
            p.count_type = find_type(w[2]);
            p.type = find_type(w[3]);
            if (p.count_type == nullptr || p.count_type->kind == Kind::real)
                fail(line_, "list count type '" + w[2] +
                                "' is not an integer type (char, uchar, short, ushort, int, "
                                "uint)");
            p.name = w[4];
            if (p.type == nullptr) fail(line_, "unknown type '" + w[3] + "' (" + type_list() + ")");
        } else {
            if (w.size() != 3) fail(line_, "expected 'property TYPE NAME'");
            p.type = find_type(w[1]);
            p.name = w[2];
            if (p.type == nullptr) fail(line_, "unknown type '" + w[1] + "' (" + type_list() + ")");
        }
        for (const Property& q : e.properties)
            if (q.name == p.name)
                fail(line_, "element '" + e.name + "' has two properties named '" + p.name + "'");
        e.properties.push_back(p);
    }

    // What the mesh is made of must be there: Open Asset Import reads a vertex without x, y or
    // z as 0 and a face element without vertex indices as none.
    void semantics(const Element& e) const {
        if (e.count > 0 && e.properties.empty())
            fail(e.line, "element '" + e.name + "' has no properties");
        auto find = [&](std::string_view name) -> const Property* {
            for (const Property& p : e.properties)
                if (p.name == name) return &p;
            return nullptr;
        };
        if (e.name == "vertex")
            for (const char* c : {"x", "y", "z"}) {
                const Property* p = find(c);
                if (p == nullptr)
                    fail(e.line, std::string("element 'vertex' has no property ") + c);
                if (p->count_type != nullptr)
                    fail(e.line, std::string("vertex property ") + c + " is a list");
            }
        if (e.name == "face" && e.count > 0) {
            const Property* p = find("vertex_indices");
            if (p == nullptr) p = find("vertex_index");
            if (p == nullptr || p->count_type == nullptr || p->type->kind == Kind::real)
                fail(e.line,
                     "element 'face' has no integer list 'vertex_indices' (or 'vertex_index')");
        }
    }

    std::string declared() const {
        std::string s;
        for (const Element& e : elements_)
            s += (s.empty() ? "" : ", ") + std::to_string(e.count) + " " + e.name;
        return s;
    }

    void ascii_data() {
        std::string_view line;
        for (const Element& e : elements_)
            for (long long i = 0; i < e.count; ++i) {
                const std::string what =
                    e.name + " " + std::to_string(i + 1) + " of " + std::to_string(e.count);
                if (!next_line(line))
                    fail(0, "the data ends before " + what + " (the header declares " + declared() +
                                ")");
                const std::vector<std::string> w = split(line);
                if (w.empty()) fail(line_, what + ": empty line");
                std::size_t k = 0;
                for (const Property& p : e.properties) {
                    if (k >= w.size())
                        fail(line_, what + ": " + std::to_string(w.size()) +
                                        " words, too few for its properties (missing '" + p.name +
                                        "')");
                    if (p.count_type == nullptr) {
                        value(what, p, *p.type, w[k++]);
                        continue;
                    }
                    long long n = 0;
                    if (!word_fits(w[k], *p.count_type, &n) || n < 0)
                        fail(line_, what + ": list '" + p.name + "' count '" + w[k] +
                                        "' is not a count of type " + p.count_type->name);
                    ++k;
                    if (static_cast<long long>(w.size() - k) < n)
                        fail(line_, what + ": list '" + p.name + "' says " + std::to_string(n) +
                                        " values, the line holds " + std::to_string(w.size() - k));
                    for (long long j = 0; j < n; ++j) value(what, p, *p.type, w[k++]);
                }
                if (k != w.size())
                    fail(line_, what + ": " + std::to_string(w.size()) +
                                    " words, its properties take " + std::to_string(k));
            }
        while (next_line(line))
            if (!trim(line).empty())
                fail(line_, "more data than the header declares (" + declared() + ")");
    }

    void value(const std::string& what, const Property& p, const Type& t,
               const std::string& w) const {
        if (!word_fits(w, t))
            fail(line_, what + ": '" + w + "' is not a value of property '" + p.name + "' (" +
                            t.name + ")");
    }

    // An integer of `t` at pos_ in the file's byte order.
    long long read_integer(const Type& t) const {
        unsigned char b[4] = {0, 0, 0, 0};
        std::memcpy(b, bytes_.data() + pos_, static_cast<std::size_t>(t.bytes));
        std::uint32_t u = 0;
        for (int k = 0; k < t.bytes; ++k) {
            const int at = format_ == Format::little_endian ? t.bytes - 1 - k : k;
            u = (u << 8) | b[at];
        }
        if (t.kind == Kind::unsigned_integer) return u;
        const int bits = 8 * t.bytes;
        const long long v = u;
        return v >= (1LL << (bits - 1)) ? v - (1LL << bits) : v;
    }

    void binary_data() {
        const std::size_t start = pos_;
        for (const Element& e : elements_) {
            bool fixed = true;
            std::size_t row = 0;
            for (const Property& p : e.properties) {
                fixed = fixed && p.count_type == nullptr;
                row += static_cast<std::size_t>(p.type->bytes);
            }
            auto short_of = [&](long long i) {
                fail(0, "the data ends inside " + e.name + " " + std::to_string(i + 1) + " of " +
                            std::to_string(e.count) + " (the header declares " + declared() +
                            "; the file holds " + std::to_string(bytes_.size() - start) +
                            " bytes of data)");
            };
            if (fixed) {
                const std::size_t left = bytes_.size() - pos_;
                if (row > 0 && static_cast<std::size_t>(e.count) > left / row)
                    short_of(static_cast<long long>(left / row));
                pos_ += static_cast<std::size_t>(e.count) * row;
                continue;
            }
            for (long long i = 0; i < e.count; ++i)
                for (const Property& p : e.properties) {
                    std::size_t need = static_cast<std::size_t>(p.type->bytes);
                    if (p.count_type != nullptr) {
                        const auto cb = static_cast<std::size_t>(p.count_type->bytes);
                        if (bytes_.size() - pos_ < cb) short_of(i);
                        const long long n = read_integer(*p.count_type);
                        if (n < 0)
                            fail(0, e.name + " " + std::to_string(i + 1) + ": list '" + p.name +
                                        "' has a negative count (" + std::to_string(n) + ")");
                        pos_ += cb;
                        need = static_cast<std::size_t>(n) * need;
                    }
                    if (bytes_.size() - pos_ < need) short_of(i);
                    pos_ += need;
                }
        }
        if (pos_ != bytes_.size())
            fail(0, std::to_string(bytes_.size() - pos_) +
                        " bytes after the data the header declares (" + declared() + ")");
    }

    std::string path_;
    std::string bytes_;
    std::size_t pos_ = 0;
    int line_ = 0;
    Format format_ = Format::ascii;
    std::vector<Element> elements_;
};

}  // namespace

void check_ply(const std::string& path) { PlyCheck(path).run(); }

}  // namespace formfactor::detail
