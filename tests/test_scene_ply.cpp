// PLY files are checked by our own reading of the format before Open Asset Import reads them
// (src/scene/ply_check.cpp): damaged headers it would loop on forever, damaged data it would
// leak on, crash on or read as zeros, are input errors naming the file and line.

#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/pipeline.h"
#include "formfactor/scene/mesh_io.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/files.h"
#include "support/mesh_files.h"
#include "support/temp_dir.h"

using namespace formfactor;
using namespace formfactor::testing;

namespace {

std::string ascii_box() { return ply(unit_box_quads("box"), false); }
std::string binary_box() { return ply(unit_box_quads("box"), true); }

// `text` with its first `from` replaced by `to`.
std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
}

// The message of loading `text` written as `name` in `dir` ("" when it loads).
std::string error_of(const TempDir& dir, const std::string& name, const std::string& text) {
    write_text(dir.file(name), text);
    return input_error([&] { load_scene(dir.file(name)); });
}

/// Edits of a file's text ({from, to}, its first `from` replaced by `to`) and the message each
/// must give after the file's path.
using Edits = std::vector<std::pair<std::pair<std::string, std::string>, std::string>>;

// Every edit of `text`, written as `name` in `dir`, fails to load with its message.
void check_edits(const TempDir& dir, const std::string& name, const std::string& text,
                 const Edits& edits) {
    for (const auto& e : edits) {
        // Not a structured binding: INFO captures it in a lambda, which clang 14 refuses.
        const auto& change = e.first;
        INFO(change.first << " -> " << change.second);
        CHECK(error_of(dir, name, replaced(text, change.first, change.second)) ==
              dir.file(name) + e.second);
    }
}

}  // namespace

TEST_CASE("ply: a header without end_header is an input error, not an endless read") {
    const TempDir dir;
    const std::string file = dir.file("cut.ply");
    // Cut inside the header, at every byte: each cut is refused (Open Asset Import 5.2.5 loops
    // forever on all of them).
    const std::string box = ascii_box();
    const std::size_t header = box.find("end_header");
    for (std::size_t n = 0; n < header + 10; ++n) {
        INFO("the first " << n << " bytes");
        CHECK_FALSE(error_of(dir, "cut.ply", box.substr(0, n)).empty());
    }
    CHECK(error_of(dir, "cut.ply", box.substr(0, header)) ==
          file + ": the header never ends: no 'end_header' line (9 lines read)");
    CHECK(error_of(dir, "cut.ply", replaced(box, "end_header", "end_heder")) ==
          file +
              ":10: 'end_heder' is not a header line of PLY (element, property, comment, "
              "obj_info, end_header)");
    CHECK(error_of(dir, "cut.ply",
                   replaced(box, "property list uchar int vertex_indices", "property list")) ==
          file + ":9: expected 'property list COUNT_TYPE TYPE NAME'");
}

TEST_CASE("ply: every line of the header is checked against the grammar") {
    const TempDir dir;
    const std::string box = ascii_box();
    const Edits cases = {
        {{"ply\n", "plx\n"}, ":1: not a PLY file: the first line is not 'ply'"},
        {{"format ascii 1.0", "format ascii"},
         ":2: expected 'format ascii 1.0' (or binary_little_endian, binary_big_endian)"},
        {{"format ascii 1.0", "format text 1.0"},
         ":2: unknown format 'text' (ascii, binary_little_endian or binary_big_endian)"},
        {{"format ascii 1.0", "format ascii 2.0"}, ":2: PLY version '2.0' (only 1.0 is known)"},
        {{"property float y", "property flot y"},
         ":6: unknown type 'flot' (char, uchar, short, ushort, int, uint, float, double, or "
         "int8, uint8, int16, uint16, int32, uint32, float32, float64)"},
        {{"property float y", "property float"}, ":6: expected 'property TYPE NAME'"},
        {{"property float y", "property float x"},
         ":6: element 'vertex' has two properties named 'x'"},
        {{"property float y", "property float q"}, ":4: element 'vertex' has no property y"},
        {{"uchar int vertex", "float int vertex"},
         ":9: list count type 'float' is not an integer type (char, uchar, short, ushort, int, "
         "uint)"},
        {{"vertex_indices", "corners"},
         ":8: element 'face' has no integer list 'vertex_indices' (or 'vertex_index')"},
        {{"element face 6", "element face"}, ":8: expected 'element NAME COUNT'"},
        {{"element face 6", "element face -6"},
         ":8: element 'face': count '-6' is not a whole number up to 2147483647"},
        {{"element face 6", "element vertex 6"},
         ":8: element 'vertex' declared twice (first at line 4)"},
        {{"element vertex 8", "elemnt vertex 8"},
         ":4: 'elemnt' is not a header line of PLY (element, property, comment, obj_info, "
         "end_header)"},
        {{"element vertex 8\n", "property float w\nelement vertex 8\n"},
         ":4: a property before any element"},
        {{"end_header", "\nend_header"}, ":10: empty line in the header"},
    };
    check_edits(dir, "h.ply", box, cases);
}

TEST_CASE("ply: ASCII data must hold what the header declares, one instance per line") {
    const TempDir dir;
    const std::string box = ascii_box();
    // Lines 11-18 are the vertices, 19-24 the faces.
    const Edits cases = {
        {{"\n1 1 0\n", "\n1 1\n"},
         ":13: vertex 3 of 8: 2 words, too few for its properties "
         "(missing 'z')"},
        {{"\n1 1 0\n", "\n1 1 0 0\n"}, ":13: vertex 3 of 8: 4 words, its properties take 3"},
        {{"\n1 1 0\n", "\n1 1x 0\n"},
         ":13: vertex 3 of 8: '1x' is not a value of property 'y' (float)"},
        {{"\n1 1 0\n", "\n1 nan 0\n"},
         ":13: vertex 3 of 8: 'nan' is not a value of property 'y' (float)"},
        {{"\n1 1 0\n", "\n\n"}, ":13: vertex 3 of 8: empty line"},
        {{"\n4 0 1 2 3\n", "\n4 0 1 2\n"},
         ":19: face 1 of 6: list 'vertex_indices' says 4 values, the line holds 3"},
        {{"\n4 0 1 2 3\n", "\n4 0 1 2.5 3\n"},
         ":19: face 1 of 6: '2.5' is not a value of property 'vertex_indices' (int)"},
        {{"\n4 0 1 2 3\n", "\n300 0 1 2 3\n"},
         ":19: face 1 of 6: list 'vertex_indices' count '300' is not a count of type uchar"},
        {{"element face 6", "element face 5"},
         ":24: more data than the header declares (8 vertex, 5 face)"},
        {{"element face 6", "element face 7"},
         ": the data ends before face 7 of 7 (the header declares 8 vertex, 7 face)"},
    };
    check_edits(dir, "d.ply", box, cases);
}

TEST_CASE("ply: binary data must be as long as the header declares") {
    const TempDir dir;
    const std::string file = dir.file("b.ply");
    const std::string box = binary_box();
    CHECK(error_of(dir, "b.ply", box.substr(0, box.size() - 30)) ==
          file +
              ": the data ends inside face 5 of 6 (the header declares 8 vertex, 6 face; the "
              "file holds 168 bytes of data)");
    CHECK(error_of(dir, "b.ply", replaced(box, "element face 6", "element face 60")) ==
          file +
              ": the data ends inside face 7 of 60 (the header declares 8 vertex, 60 face; "
              "the file holds 198 bytes of data)");
    CHECK(error_of(dir, "b.ply", replaced(box, "element vertex 8", "element vertex 800")) ==
          file +
              ": the data ends inside vertex 17 of 800 (the header declares 800 vertex, 6 "
              "face; the file holds 198 bytes of data)");
    CHECK(error_of(dir, "b.ply", box + "xy") ==
          file + ": 2 bytes after the data the header declares (8 vertex, 6 face)");
    // A signed list count below zero.
    std::string negative = replaced(box, "list uchar int", "list char int");
    negative[negative.find("end_header\n") + 11 + 8 * 12] = static_cast<char>(-4);
    CHECK(error_of(dir, "b.ply", negative) ==
          file + ": face 1: list 'vertex_indices' has a negative count (-4)");
}

TEST_CASE("ply: an element Open Asset Import reads no data of is refused before one it reads") {
    const TempDir dir;
    const std::string file = dir.file("e.ply");
    const std::string box = ascii_box();
    // ":N" for the line of `text` that starts with `what`.
    auto line_of = [](const std::string& text, const std::string& what) {
        const auto before = std::count(text.begin(), text.begin() + text.find(what), '\n');
        return ":" + std::to_string(before + 1);
    };
    // Named with digits: the reader would take 4294967295 from the name as the count and
    // allocate for it (found by the mesh fuzzer).
    const std::string digits =
        replaced(box, "end_header", "element 4294967295 0\nproperty float q\nend_header");
    CHECK(error_of(dir, "e.ply", digits) ==
          file + line_of(digits, "element 4294967295") +
              ": element '4294967295': a name that starts with a digit (Open Asset Import reads "
              "it as the element's count)");
    // An element of its own before the vertices: the reader would skip its line and read it as
    // the first vertex.
    std::string before = replaced(box, "element vertex",
                                  "element camera 1\nproperty float "
                                  "view_px\nelement vertex");
    const std::size_t data = before.find("end_header\n") + 11;
    before.insert(data, "0.5\n");
    CHECK(error_of(dir, "e.ply", before) ==
          file + line_of(before, "element camera") +
              ": element 'camera' (1) comes before element 'vertex': Open Asset Import skips the "
              "data of elements other than vertex, face, tristrips, edge and material, and would "
              "misread what follows; move it after them");
    // With no instances, or after the elements it reads, such an element is harmless.
    CHECK(error_of(dir, "e.ply",
                   replaced(box, "element vertex",
                            "element camera 0\nproperty "
                            "float view_px\nelement vertex")) == "");
}

TEST_CASE(
    "ply: files as writers make them load: comments, extra properties, elements, CRLF, "
    "big-endian") {
    const TempDir dir;
    const DenseMatrix F =
        compute_form_factors(load_scene(data("../../examples/meshes/room.ply"))).form_factors.F;
    CHECK(F.rows() == 6);
    // Extra per-vertex properties (normals, colours), obj_info, an element the reader skips.
    std::string rich = replaced(ascii_box(), "property float z\n",
                                "property float z\nproperty float nx\nproperty uchar red\n");
    rich = replaced(rich, "comment", "obj_info scanned\ncomment");
    rich = replaced(rich, "end_header", "element camera 1\nproperty float view_px\nend_header");
    std::string body = rich.substr(rich.find("end_header\n") + 11);
    rich.resize(rich.find("end_header\n") + 11);
    std::size_t lines = 0;
    for (std::size_t at = 0; at < body.size(); at = body.find('\n', at) + 1) {
        const std::size_t end = body.find('\n', at);
        rich += body.substr(at, end - at) + (lines++ < 8 ? " -1e-0 255" : "") + "\n";
    }
    rich += "0.5\n";
    CHECK(error_of(dir, "rich.ply", rich) == "");
    // CRLF line ends, and no line end after the last face.
    std::string crlf;
    for (char c : ascii_box()) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    crlf.resize(crlf.size() - 2);
    CHECK(error_of(dir, "crlf.ply", crlf) == "");
    // Big-endian: the binary box with its numbers byte-swapped.
    const TestMesh box = unit_box_quads("box");
    std::string be = replaced(ply(box, false), "ascii", "binary_big_endian");
    be.resize(be.find("end_header\n") + 11);
    auto put_be = [&](std::uint32_t u, int bytes) {
        for (int k = bytes - 1; k >= 0; --k) be += static_cast<char>((u >> (8 * k)) & 0xff);
    };
    for (const Vec3& v : box.vertices)
        for (int k = 0; k < 3; ++k) {
            const float x = static_cast<float>(v[k]);
            std::uint32_t u = 0;
            std::memcpy(&u, &x, 4);
            put_be(u, 4);
        }
    for (const auto& f : box.faces) {
        put_be(static_cast<std::uint32_t>(f.size()), 1);
        for (int i : f) put_be(static_cast<std::uint32_t>(i), 4);
    }
    write_text(dir.file("be.ply"), be);
    write_text(dir.file("le.ply"), binary_box());
    const DenseMatrix Fbe = compute_form_factors(load_scene(dir.file("be.ply"))).form_factors.F;
    const DenseMatrix Fle = compute_form_factors(load_scene(dir.file("le.ply"))).form_factors.F;
    CHECK((Fbe - Fle).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("ply: the CLI refuses a PLY whose header never ends with one message, nothing written") {
    Cli cli;
    const std::string box = ascii_box();
    write_text(cli.file("cut.ply"), box.substr(0, box.find("end_header")));
    const CliResult r = cli.run("compute cut.ply -o F.csv");
    INFO(r.out << r.err);
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK(r.err.find("cut.ply: the header never ends: no 'end_header' line") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(cli.file("F.csv")));
}
