// Gmsh meshes (.msh): our own reader of the documented format (the Gmsh SDK is GPL), versions
// 2.2 and 4.1, ASCII and binary, as Gmsh's reference manual ("MSH file format") describes them.
//
// Sections are `$Name` ... `$EndName`; the reader uses $MeshFormat, $PhysicalNames, $Entities
// (4.1), $Nodes and $Elements and skips any other. Binary files keep the section headers, the
// counts of 2.2 and $PhysicalNames in text, and the rest as little-endian ints (4 bytes),
// doubles and, in 4.1, size_t (the data size of $MeshFormat, 8). 2.2 elements carry their tags
// (the first is the physical group, the second the elementary entity); 4.1 elements come in
// blocks per entity, and the entity's physical groups are in $Entities.
//
// Triangles (type 2) and quads (type 3) are the surfaces; points and lines are ignored, volume
// elements ignored with a warning, curved (second-order) surface elements refused. The file
// is read whole: this file is longer than most because both versions and both encodings live
// here, behind one cursor.

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/mesh_io.h"
#include "scene/text.h"

namespace formfactor {

namespace {

using detail::short_number;

// Nodes per element type, from Gmsh's manual (0: not a type we know).
int nodes_of_type(int type) {
    static constexpr std::array<int, 32> kNodes = {0,  2,  3,  4,  4, 8, 6,  5,  3,  6, 9,
                                                   10, 27, 18, 14, 1, 8, 20, 15, 13, 9, 10,
                                                   12, 15, 15, 21, 4, 5, 6,  20, 35, 56};
    if (type >= 1 && type < static_cast<int>(kNodes.size())) return kNodes[type];
    if (type == 92) return 64;
    if (type == 93) return 125;
    return 0;
}

// The dimension of an element type (-1 when unknown).
int dim_of_type(int type) {
    switch (type) {
        case 15:
            return 0;
        case 1:
        case 8:
        case 26:
        case 27:
        case 28:
            return 1;
        case 2:
        case 3:
        case 9:
        case 10:
        case 16:
        case 20:
        case 21:
        case 22:
        case 23:
        case 24:
        case 25:
            return 2;
        default:
            return nodes_of_type(type) > 0 ? 3 : -1;
    }
}

struct Element {
    std::size_t tag = 0;
    std::vector<std::size_t> nodes;  // node tags, as in the file
    int group = -1;                  // index into MshReader::groups_
    int line = 0;                    // ASCII: its line; binary: 0
};

struct Group {
    std::string name;
    bool obstruction = false;
    int first_surface = -1;
};

bool starts_with_obstruction(const std::string& name) {
    const std::string p = "obstruction";
    if (name.size() < p.size()) return false;
    for (std::size_t k = 0; k < p.size(); ++k)
        if (std::tolower(static_cast<unsigned char>(name[k])) != p[k]) return false;
    return true;
}

class MshReader {
  public:
    explicit MshReader(std::string path) : path_(std::move(path)) {}

    Scene read() {
        std::ifstream in(path_, std::ios::binary);
        if (!in || std::filesystem::is_directory(path_))
            throw InputError(path_, 0, "cannot open file");
        std::ostringstream s;
        s << in.rdbuf();
        if (in.bad()) throw InputError(path_, 0, "cannot read file");
        buf_ = s.str();
        scene_.name = path_;

        if (word() != "$MeshFormat") fail("not a Gmsh mesh: the file must begin with $MeshFormat");
        mesh_format();
        bool nodes = false, elements = false;
        while (true) {
            skip_space();
            if (pos_ >= buf_.size()) break;
            const std::size_t at = pos_;
            const std::string w = word();
            if (w.size() < 2 || w[0] != '$')
                fail_at(at, "expected a section ($Name), found '" + w.substr(0, 40) + "'");
            const std::string name = w.substr(1);
            if (name == "PhysicalNames") {
                physical_names();
            } else if (name == "Entities" && major_ == 4) {
                entities();
            } else if (name == "Nodes") {
                if (major_ == 4)
                    nodes4();
                else
                    nodes2();
                nodes = true;
            } else if (name == "Elements") {
                if (!nodes) fail_at(at, "$Elements before $Nodes");
                if (major_ == 4)
                    elements4();
                else
                    elements2();
                elements = true;
            } else {
                skip_section(name, at);
                continue;
            }
            expect_end(name);
        }
        if (!elements) fail("no $Elements section: the file holds no mesh");
        build();
        return std::move(scene_);
    }

  private:
    // --- errors -------------------------------------------------------------------------
    // The line of byte `at` (0 in a binary file); counted on from the last call, so that
    // asking in file order costs one pass.
    int line_at(std::size_t at) const {
        if (binary_) return 0;
        at = std::min(at, buf_.size());
        if (at < counted_to_) counted_to_ = 0, counted_lines_ = 0;
        counted_lines_ +=
            static_cast<int>(std::count(buf_.begin() + static_cast<std::ptrdiff_t>(counted_to_),
                                        buf_.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
        counted_to_ = at;
        return 1 + counted_lines_;
    }
    [[noreturn]] void fail_at(std::size_t at, const std::string& msg) const {
        if (binary_) throw InputError(path_, 0, "byte " + std::to_string(at) + ": " + msg);
        throw InputError(path_, line_at(at), msg);
    }
    [[noreturn]] void fail(const std::string& msg) const { fail_at(pos_, msg); }
    std::string element_name(const Element& e) const { return "element " + std::to_string(e.tag); }

    // --- text ---------------------------------------------------------------------------
    void skip_space() {
        while (pos_ < buf_.size() && std::isspace(static_cast<unsigned char>(buf_[pos_]))) ++pos_;
    }
    std::string word() {
        skip_space();
        const std::size_t b = pos_;
        while (pos_ < buf_.size() && !std::isspace(static_cast<unsigned char>(buf_[pos_]))) ++pos_;
        return buf_.substr(b, pos_ - b);
    }
    std::string need_word(const char* what) {
        skip_space();
        if (pos_ >= buf_.size()) fail(std::string("unexpected end of file: expected ") + what);
        return word();
    }
    double text_double(const char* what) {
        const std::size_t at = (skip_space(), pos_);
        const std::string w = need_word(what);
        double x = 0.0;
        if (!detail::parse_double(w, x))
            fail_at(at, "malformed number '" + w.substr(0, 40) + "' (" + what + ")");
        if (!std::isfinite(x)) fail_at(at, std::string(what) + " '" + w + "' is not finite");
        return x;
    }
    long long text_int(const char* what) {
        const std::size_t at = (skip_space(), pos_);
        const std::string w = need_word(what);
        const bool neg = !w.empty() && w[0] == '-';
        std::size_t v = 0;
        if (!detail::parse_size(neg ? w.substr(1) : w, v) || v > (std::size_t{1} << 62))
            fail_at(at, "malformed integer '" + w.substr(0, 40) + "' (" + what + ")");
        return neg ? -static_cast<long long>(v) : static_cast<long long>(v);
    }
    std::size_t text_count(const char* what) {
        const std::size_t at = (skip_space(), pos_);
        const long long v = text_int(what);
        if (v < 0) fail_at(at, std::string(what) + " is negative");
        return static_cast<std::size_t>(v);
    }
    std::string rest_of_line() {
        const std::size_t b = pos_;
        while (pos_ < buf_.size() && buf_[pos_] != '\n') ++pos_;
        return buf_.substr(b, pos_ - b);
    }

    // --- binary -------------------------------------------------------------------------
    template <class T>
    T raw(const char* what) {
        if (buf_.size() - pos_ < sizeof(T) || pos_ > buf_.size())
            fail(std::string("unexpected end of file: expected ") + what);
        T v;
        std::memcpy(&v, buf_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return v;
    }
    // After a text line that precedes binary data: exactly one '\n'.
    void end_text_line() {
        while (pos_ < buf_.size() && (buf_[pos_] == ' ' || buf_[pos_] == '\r')) ++pos_;
        if (pos_ >= buf_.size() || buf_[pos_] != '\n') fail("expected the end of the line");
        ++pos_;
    }
    // Refuses a count whose records (at least `bytes_each` bytes each, text or binary) cannot
    // fit in the rest of the file, before anything is reserved for it.
    void check_count(std::size_t n, std::size_t bytes_each, const char* what) {
        const std::size_t left = buf_.size() - std::min(pos_, buf_.size());
        if (bytes_each > 0 && n > left / bytes_each)
            fail(std::string("the file claims ") + std::to_string(n) + " " + what +
                 ", more than it can hold");
    }

    // A number of the file's kind: text or binary int / size_t / double.
    long long int_value(const char* what) {
        return binary_ ? static_cast<long long>(raw<std::int32_t>(what)) : text_int(what);
    }
    std::size_t size_value(const char* what) {
        if (!binary_) return text_count(what);
        const std::uint64_t v = raw<std::uint64_t>(what);
        if (v > (std::uint64_t{1} << 62)) fail(std::string(what) + " is out of range");
        return static_cast<std::size_t>(v);
    }
    double double_value(const char* what) {
        if (!binary_) return text_double(what);
        const std::size_t at = pos_;
        const double x = raw<double>(what);
        if (!std::isfinite(x)) fail_at(at, std::string(what) + " is not finite");
        return x;
    }

    // --- sections -----------------------------------------------------------------------
    void mesh_format() {
        const std::size_t at = (skip_space(), pos_);
        const std::string version = need_word("the version");
        const long long file_type = text_int("the file type");
        const long long data_size = text_int("the data size");
        if (version == "4.1") {
            major_ = 4;
        } else if (version == "2.2" || version == "2.1" || version == "2") {
            major_ = 2;
        } else {
            fail_at(at, "MSH version " + version +
                            " is not supported (2.2 and 4.1 are: save with -format msh22 or "
                            "msh41)");
        }
        if (file_type != 0 && file_type != 1) fail_at(at, "file type must be 0 or 1");
        if (data_size != 8)
            fail_at(at, "data size " + std::to_string(data_size) + " is not supported (8)");
        if (file_type == 1) {
            end_text_line();
            const std::size_t one_at = pos_;
            const std::int32_t one = raw<std::int32_t>("the binary check");
            binary_ = true;
            if (one != 1)
                fail_at(
                    one_at,
                    "binary check is not 1: a big-endian file (not supported) or a damaged one");
        }
        expect_end("MeshFormat");
    }

    void expect_end(const std::string& name) {
        const std::size_t at = (skip_space(), pos_);
        const std::string w = word();
        if (w != "$End" + name)
            fail_at(at, "expected $End" + name + ", found '" + w.substr(0, 40) + "'");
    }

    void skip_section(const std::string& name, std::size_t at) {
        const std::string end = "\n$End" + name;
        const std::size_t e = buf_.find(end, pos_);
        if (e == std::string::npos) fail_at(at, "section $" + name + " has no $End" + name);
        pos_ = e + end.size();
    }

    void physical_names() {
        const std::size_t n = text_count("the number of physical names");
        check_count(n, 6, "physical names");
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t at = (skip_space(), pos_);
            const long long dim = text_int("the dimension of a physical name");
            const long long tag = text_int("the tag of a physical name");
            std::string rest = detail::trim(rest_of_line());
            if (rest.size() < 2 || rest.front() != '"' || rest.back() != '"')
                fail_at(at, "physical name must be in double quotes");
            rest = rest.substr(1, rest.size() - 2);
            if (dim == 2) physical_names_[tag] = rest;
        }
    }

    // 4.1: the physical groups of each surface entity.
    void entities() {
        if (binary_) end_text_line();
        const std::size_t at = pos_;
        std::array<std::size_t, 4> count{};
        for (std::size_t& c : count) c = size_value("the number of entities");
        const std::size_t total = count[0] + count[1] + count[2] + count[3];
        if (total < count[0]) fail_at(at, "entity counts out of range");
        check_count(total, binary_ ? 32 : 8, "entities");
        for (int dim = 0; dim < 4; ++dim) {
            for (std::size_t k = 0; k < count[static_cast<std::size_t>(dim)]; ++k) {
                const long long tag = int_value("an entity tag");
                for (int c = 0; c < (dim == 0 ? 3 : 6); ++c) double_value("an entity's bounds");
                const std::size_t np = size_value("the number of physical tags");
                check_count(np, binary_ ? 4 : 2, "physical tags");
                std::vector<long long> phys;
                for (std::size_t p = 0; p < np; ++p) phys.push_back(int_value("a physical tag"));
                if (dim == 2) surface_physicals_[tag] = phys;
                if (dim > 0) {
                    const std::size_t nb = size_value("the number of bounding entities");
                    check_count(nb, binary_ ? 4 : 2, "bounding entities");
                    for (std::size_t b = 0; b < nb; ++b) int_value("a bounding entity");
                }
            }
        }
    }

    void add_node(std::size_t tag, const Vec3& x, std::size_t at) {
        if (!nodes_.emplace(tag, x).second)
            fail_at(at, "node " + std::to_string(tag) + " is defined twice");
    }

    void nodes2() {
        const std::size_t n = text_count("the number of nodes");
        check_count(n, binary_ ? 28 : 8, "nodes");
        nodes_.reserve(n);
        if (binary_) end_text_line();
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t at = (binary_ ? pos_ : (skip_space(), pos_));
            const long long tag = int_value("a node tag");
            if (tag <= 0) fail_at(at, "node tag " + std::to_string(tag) + " is not positive");
            Vec3 x;
            for (int c = 0; c < 3; ++c) x[c] = double_value("a node coordinate");
            add_node(static_cast<std::size_t>(tag), x, at);
        }
    }

    void nodes4() {
        if (binary_) end_text_line();
        std::array<std::size_t, 4> head{};
        for (std::size_t& h : head) h = size_value("the $Nodes header");
        const std::size_t blocks = head[0], n = head[1];
        check_count(blocks, binary_ ? 20 : 8, "node blocks");
        check_count(n, binary_ ? 32 : 8, "nodes");
        nodes_.reserve(n);
        std::size_t seen = 0;
        for (std::size_t b = 0; b < blocks; ++b) {
            const long long dim = int_value("an entity dimension");
            int_value("an entity tag");
            const long long parametric = int_value("the parametric flag");
            const std::size_t m = size_value("the number of nodes in a block");
            if (dim < 0 || dim > 3) fail("entity dimension " + std::to_string(dim) + " invalid");
            if (parametric != 0 && parametric != 1) fail("parametric flag must be 0 or 1");
            const std::size_t per = 3 + (parametric ? static_cast<std::size_t>(dim) : 0);
            check_count(m, binary_ ? 8 * (1 + per) : 2 * (1 + per), "nodes in a block");
            std::vector<std::size_t> tags(m);
            std::vector<std::size_t> where(m);
            for (std::size_t k = 0; k < m; ++k) {
                where[k] = (binary_ ? pos_ : (skip_space(), pos_));
                tags[k] = size_value("a node tag");
            }
            for (std::size_t k = 0; k < m; ++k) {
                Vec3 x;
                for (int c = 0; c < 3; ++c) x[c] = double_value("a node coordinate");
                for (std::size_t c = 3; c < per; ++c) double_value("a parametric coordinate");
                add_node(tags[k], x, where[k]);
            }
            seen += m;
        }
        if (seen != n)
            fail("$Nodes announces " + std::to_string(n) + " nodes, the blocks hold " +
                 std::to_string(seen));
    }

    // The group of an element: its physical group when it has one, else its entity.
    int group_of(long long physical, long long entity) {
        const bool phys = physical != 0;
        const std::pair<bool, long long> key{phys, phys ? physical : entity};
        const auto it = group_index_.find(key);
        if (it != group_index_.end()) return it->second;
        Group g;
        if (phys) {
            const auto n = physical_names_.find(physical);
            g.name =
                n != physical_names_.end() ? n->second : "physical-" + std::to_string(physical);
        } else {
            g.name = "surface-" + std::to_string(entity);
        }
        g.obstruction = starts_with_obstruction(g.name);
        groups_.push_back(g);
        const int index = static_cast<int>(groups_.size()) - 1;
        group_index_[key] = index;
        return index;
    }

    // One element read: kept when it is a flat surface element.
    void element(std::size_t tag, int type, std::vector<std::size_t> nodes, long long physical,
                 long long entity, std::size_t at) {
        const int dim = dim_of_type(type);
        if (dim == 3) {
            ++volume_elements_;
            return;
        }
        if (dim != 2) return;
        if (type != 2 && type != 3)
            fail_at(at, "element " + std::to_string(tag) + " is a curved (type " +
                            std::to_string(type) +
                            ", second order or higher) surface element: mesh with order 1");
        Element e;
        e.tag = tag;
        e.nodes = std::move(nodes);
        e.group = group_of(physical, entity);
        e.line = line_at(at);
        elements_.push_back(std::move(e));
    }

    void elements2() {
        const std::size_t n = text_count("the number of elements");
        check_count(n, binary_ ? 12 : 8, "elements");
        if (!binary_) {
            for (std::size_t k = 0; k < n; ++k) {
                const std::size_t at = (skip_space(), pos_);
                const long long tag = text_int("an element tag");
                const long long type = text_int("an element type");
                const long long ntags = text_int("the number of tags");
                const int nn = nodes_of_type(static_cast<int>(std::clamp(type, -1LL, 1000LL)));
                if (nn == 0) fail_at(at, "unknown element type " + std::to_string(type));
                if (ntags < 0 || ntags > 100) fail_at(at, "invalid number of tags");
                std::vector<long long> tags;
                for (long long t = 0; t < ntags; ++t) tags.push_back(text_int("an element tag"));
                std::vector<std::size_t> nodes;
                for (int v = 0; v < nn; ++v) nodes.push_back(text_count("a node tag"));
                element(static_cast<std::size_t>(tag), static_cast<int>(type), std::move(nodes),
                        tags.size() > 0 ? tags[0] : 0, tags.size() > 1 ? tags[1] : 0, at);
            }
            return;
        }
        end_text_line();
        std::size_t seen = 0;
        while (seen < n) {
            const std::size_t at = pos_;
            const std::int32_t type = raw<std::int32_t>("an element type");
            const std::int32_t follow = raw<std::int32_t>("the number of elements that follow");
            const std::int32_t ntags = raw<std::int32_t>("the number of tags");
            const int nn = nodes_of_type(type);
            if (nn == 0) fail_at(at, "unknown element type " + std::to_string(type));
            if (follow <= 0 || static_cast<std::size_t>(follow) > n - seen)
                fail_at(at, "element block of " + std::to_string(follow) +
                                " elements does not fit the announced " + std::to_string(n));
            if (ntags < 0 || ntags > 100) fail_at(at, "invalid number of tags");
            check_count(static_cast<std::size_t>(follow),
                        4 * static_cast<std::size_t>(1 + ntags + nn), "elements");
            for (std::int32_t k = 0; k < follow; ++k) {
                const std::size_t eat = pos_;
                const std::int32_t tag = raw<std::int32_t>("an element tag");
                std::vector<long long> tags;
                for (std::int32_t t = 0; t < ntags; ++t)
                    tags.push_back(raw<std::int32_t>("an element tag"));
                std::vector<std::size_t> nodes;
                for (int v = 0; v < nn; ++v) {
                    const std::int32_t node = raw<std::int32_t>("a node tag");
                    if (node <= 0) fail_at(eat, "node tag " + std::to_string(node) + " invalid");
                    nodes.push_back(static_cast<std::size_t>(node));
                }
                element(static_cast<std::size_t>(tag < 0 ? 0 : tag), type, std::move(nodes),
                        tags.size() > 0 ? tags[0] : 0, tags.size() > 1 ? tags[1] : 0, eat);
            }
            seen += static_cast<std::size_t>(follow);
        }
    }

    void elements4() {
        if (binary_) end_text_line();
        std::array<std::size_t, 4> head{};
        for (std::size_t& h : head) h = size_value("the $Elements header");
        const std::size_t blocks = head[0], n = head[1];
        check_count(blocks, binary_ ? 20 : 8, "element blocks");
        check_count(n, binary_ ? 16 : 4, "elements");
        std::size_t seen = 0;
        for (std::size_t b = 0; b < blocks; ++b) {
            const std::size_t at = (binary_ ? pos_ : (skip_space(), pos_));
            const long long dim = int_value("an entity dimension");
            const long long entity = int_value("an entity tag");
            const long long type = int_value("an element type");
            const std::size_t m = size_value("the number of elements in a block");
            const int nn = nodes_of_type(static_cast<int>(std::clamp(type, -1LL, 1000LL)));
            if (nn == 0) fail_at(at, "unknown element type " + std::to_string(type));
            if (dim != dim_of_type(static_cast<int>(type)))
                fail_at(at, "element type " + std::to_string(type) + " in an entity of dimension " +
                                std::to_string(dim));
            check_count(m, (binary_ ? 8 : 2) * static_cast<std::size_t>(1 + nn), "elements");
            long long physical = 0;
            if (dim == 2) {
                const auto it = surface_physicals_.find(entity);
                if (it != surface_physicals_.end() && !it->second.empty()) {
                    physical = it->second[0];
                    if (it->second.size() > 1)
                        fail_at(at, "surface entity " + std::to_string(entity) +
                                        " is in several physical groups (" +
                                        group_label(it->second[0]) + " and " +
                                        group_label(it->second[1]) +
                                        "): a patch can belong to one surface only");
                }
            }
            for (std::size_t k = 0; k < m; ++k) {
                const std::size_t eat = (binary_ ? pos_ : (skip_space(), pos_));
                const std::size_t tag = size_value("an element tag");
                std::vector<std::size_t> nodes;
                for (int v = 0; v < nn; ++v) nodes.push_back(size_value("a node tag"));
                element(tag, static_cast<int>(type), std::move(nodes), physical, entity, eat);
            }
            seen += m;
        }
        if (seen != n)
            fail("$Elements announces " + std::to_string(n) + " elements, the blocks hold " +
                 std::to_string(seen));
    }

    std::string group_label(long long physical) const {
        const auto n = physical_names_.find(physical);
        return n != physical_names_.end() ? "'" + n->second + "'"
                                          : "physical-" + std::to_string(physical);
    }

    // --- the scene ----------------------------------------------------------------------
    [[noreturn]] void fail_element(const Element& e, const std::string& msg) const {
        throw InputError(path_, e.line, msg);
    }

    void build() {
        if (volume_elements_ > 0)
            scene_.warnings.push_back(path_ + ": " + std::to_string(volume_elements_) +
                                      " volume elements ignored (the surface elements are the "
                                      "patches)");
        scene_.materials.push_back(Material{});
        // The same nodes twice: an element in two physical groups (2.2 writes it once per
        // group) or a duplicate; either would make two coincident patches.
        std::map<std::vector<std::size_t>, std::size_t> seen;
        for (std::size_t k = 0; k < elements_.size(); ++k) {
            const Element& e = elements_[k];
            std::vector<std::size_t> key = e.nodes;
            std::sort(key.begin(), key.end());
            const auto [it, fresh] = seen.emplace(std::move(key), k);
            if (!fresh) {
                const Element& f = elements_[it->second];
                fail_element(e, element_name(e) + " (in '" +
                                    groups_[static_cast<std::size_t>(e.group)].name +
                                    "') has the same nodes as " + element_name(f) + " (in '" +
                                    groups_[static_cast<std::size_t>(f.group)].name +
                                    "'): a patch can belong to one surface only");
            }
        }
        for (const Element& e : elements_) {
            Surface s;
            Group& g = groups_[static_cast<std::size_t>(e.group)];
            s.name = g.name;
            s.obstruction = g.obstruction;
            s.where = {path_, e.line};
            for (std::size_t node : e.nodes) {
                const auto it = nodes_.find(node);
                if (it == nodes_.end())
                    fail_element(e, element_name(e) + " refers to node " + std::to_string(node) +
                                        ", which the file does not define");
                s.polygon.vertices.push_back(it->second);
            }
            validate_polygon(s.polygon, s.where, element_name(e));
            s.material = 0;
            const int index = static_cast<int>(scene_.surfaces.size());
            if (g.first_surface < 0)
                g.first_surface = index;
            else if (!g.obstruction)
                s.combine = g.first_surface;
            scene_.surfaces.push_back(std::move(s));
        }
        std::vector<std::size_t> all;
        for (std::size_t k = 0; k < elements_.size(); ++k)
            if (!groups_[static_cast<std::size_t>(elements_[k].group)].obstruction)
                all.push_back(k);
        check_orientation(all);
        for (std::size_t g = 0; g < groups_.size(); ++g) {
            std::vector<std::size_t> members;
            for (std::size_t k = 0; k < elements_.size(); ++k)
                if (elements_[k].group == static_cast<int>(g)) members.push_back(k);
            check_orientation(members);
        }
    }

    // A closed surface (every edge of its elements shared by exactly two of them) must be
    // oriented consistently: two neighbours run through their shared edge in opposite
    // directions. Components are found through such edges; in a closed component whose
    // elements disagree, the smaller class is named.
    void check_orientation(const std::vector<std::size_t>& members) const {
        struct Use {
            std::size_t element;
            bool forward;
        };
        std::map<std::pair<std::size_t, std::size_t>, std::vector<Use>> edges;
        for (std::size_t e : members) {
            const std::vector<std::size_t>& v = elements_[e].nodes;
            for (std::size_t k = 0; k < v.size(); ++k) {
                const std::size_t a = v[k], b = v[(k + 1) % v.size()];
                edges[{std::min(a, b), std::max(a, b)}].push_back({e, a < b});
            }
        }
        std::unordered_map<std::size_t, std::vector<std::pair<std::size_t, bool>>> next;
        std::set<std::size_t> open;  // elements with an edge not shared by exactly two
        for (const auto& [key, uses] : edges) {
            if (uses.size() != 2) {
                for (const Use& u : uses) open.insert(u.element);
                continue;
            }
            const bool same = uses[0].forward == uses[1].forward;
            next[uses[0].element].push_back({uses[1].element, same});
            next[uses[1].element].push_back({uses[0].element, same});
        }
        std::unordered_map<std::size_t, int> flip;
        for (std::size_t root : members) {
            if (flip.count(root)) continue;
            std::vector<std::size_t> component{root}, stack{root};
            flip[root] = 0;
            bool closed = true;
            while (!stack.empty()) {
                const std::size_t e = stack.back();
                stack.pop_back();
                if (open.count(e)) closed = false;
                for (const auto& [n, same] : next[e]) {
                    if (flip.count(n)) continue;
                    flip[n] = flip[e] ^ (same ? 1 : 0);
                    component.push_back(n);
                    stack.push_back(n);
                }
            }
            if (!closed) continue;
            std::size_t flipped = 0;
            for (std::size_t e : component) flipped += static_cast<std::size_t>(flip[e]);
            if (flipped == 0) continue;
            const int minority = 2 * flipped <= component.size() ? 1 : 0;
            std::sort(component.begin(), component.end());
            const std::size_t odd_count = minority ? flipped : component.size() - flipped;
            for (std::size_t e : component) {
                if (flip[e] != minority) continue;
                const Element& el = elements_[e];
                fail_element(el, element_name(el) + " (in '" +
                                     groups_[static_cast<std::size_t>(el.group)].name +
                                     "') faces the other way from its neighbours on a closed "
                                     "surface (" +
                                     std::to_string(odd_count) + " of its " +
                                     std::to_string(component.size()) +
                                     " elements do): the node order gives the front, "
                                     "counter-clockwise seen from the front");
            }
        }
    }

    std::string path_;
    std::string buf_;
    std::size_t pos_ = 0;
    int major_ = 2;
    bool binary_ = false;
    Scene scene_;
    std::map<long long, std::string> physical_names_;
    std::map<long long, std::vector<long long>> surface_physicals_;
    std::unordered_map<std::size_t, Vec3> nodes_;
    std::vector<Element> elements_;
    std::vector<Group> groups_;
    std::map<std::pair<bool, long long>, int> group_index_;
    std::size_t volume_elements_ = 0;
    mutable std::size_t counted_to_ = 0;
    mutable int counted_lines_ = 0;
};

}  // namespace

Scene load_msh(const std::string& path) {
    Scene scene = MshReader(path).read();
    detail::require_surfaces(scene, path, "no triangles or quads",
                             "physical groups named obstruction* only block");
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

}  // namespace formfactor
