#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/patch_table.h"
#include "formfactor/output/report.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::read_text;
using formfactor::testing::TempDir;
using formfactor::testing::write_text;

namespace {

/// A matrix of awkward doubles: signs, tiny, huge, subnormal, zero, -0, many digits.
DenseMatrix awkward_matrix(int n) {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    DenseMatrix F(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) F(i, j) = u(rng) * std::pow(10.0, (i * 7 + j * 3) % 40 - 20);
    F(0, 0) = 0.0;
    if (n > 1) {
        F(0, 1) = -0.0;
        F(1, 0) = std::numeric_limits<double>::denorm_min();
        F(1, 1) = std::numeric_limits<double>::max();
    }
    if (n > 2) F(2, 2) = 0.1;
    return F;
}

bool bit_equal(const DenseMatrix& a, const DenseMatrix& b) {
    if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
    for (Eigen::Index k = 0; k < a.size(); ++k) {
        if (std::bit_cast<std::uint64_t>(a.data()[k]) != std::bit_cast<std::uint64_t>(b.data()[k]))
            return false;
    }
    return true;
}

std::string what_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "";
}

}  // namespace

// ---- atomic writing ---------------------------------------------------------------------------

TEST_CASE("output: atomic write creates the file and leaves no temporary") {
    TempDir dir;
    const std::string path = dir.file("a.txt");
    write_file_atomically(path, [](std::ostream& out) { out << "hello\n"; });
    CHECK(read_text(path) == "hello\n");
    CHECK(dir.entries() == 1);
    CHECK(temporary_path_for(path).find(path + ".tmp.") == 0);
}

TEST_CASE("output: a failure mid-write leaves nothing behind and keeps an existing file") {
    TempDir dir;
    const std::string path = dir.file("F.csv");
    auto failing = [](std::ostream& out) {
        for (int k = 0; k < 100000; ++k) out << "0.123456789,";  // > one buffer of bytes
        throw GeometryError("simulated failure");
    };
    CHECK_THROWS_AS(write_file_atomically(path, failing), GeometryError);
    CHECK(dir.entries() == 0);

    write_text(path, "old\n");
    CHECK_THROWS_AS(write_file_atomically(path, failing), GeometryError);
    CHECK(read_text(path) == "old\n");
    CHECK(dir.entries() == 1);
}

TEST_CASE("output: writing into a missing directory is an InputError naming the file") {
    TempDir dir;
    const std::string path = dir.file("no/such/dir/F.csv");
    const std::string msg =
        what_of([&] { write_file_atomically(path, [](std::ostream& out) { out << "x"; }); });
    CHECK(msg.find(path + ": ") == 0);
    CHECK(msg.find("does not exist") != std::string::npos);
    CHECK_THROWS_AS(check_output_directory(path), InputError);
    CHECK_NOTHROW(check_output_directory(dir.file("ok.csv")));
    CHECK_NOTHROW(check_output_directory("relative.csv"));
}

TEST_CASE("output: a transaction writes all files or none") {
    TempDir dir;
    {
        OutputTransaction tx;
        tx.stage(dir.file("a.csv"), [](std::ostream& out) { out << "a"; });
        CHECK_THROWS_AS(
            tx.stage(dir.file("b.json"),
                     [](std::ostream&) { throw InputError("b.json", 3, "simulated failure"); }),
            InputError);
        CHECK(tx.paths().size() == 1);
    }  // not committed: a.csv's temporary is removed too
    CHECK(dir.entries() == 0);

    OutputTransaction tx;
    tx.stage(dir.file("a.csv"), [](std::ostream& out) { out << "a"; });
    tx.stage(dir.file("b.json"), [](std::ostream& out) { out << "{}"; });
    CHECK_THROWS_AS(tx.stage(dir.file("a.csv"), [](std::ostream&) {}), Error);
    CHECK(dir.entries() == 2);  // the two temporaries
    CHECK_FALSE(std::filesystem::exists(dir.file("a.csv")));
    tx.commit();
    CHECK(read_text(dir.file("a.csv")) == "a");
    CHECK(read_text(dir.file("b.json")) == "{}");
    CHECK(dir.entries() == 2);
}

TEST_CASE("output: files staged by name and adopted from another transaction commit together") {
    TempDir dir;
    {
        OutputTransaction outer;
        OutputTransaction one;
        // A writer that opens the file itself sees a name with the target's extension.
        one.stage_file(dir.file("F.h5"), [](const std::string& staged) {
            CHECK(std::filesystem::path(staged).extension() == ".h5");
            std::ofstream(staged) << "h5";
        });
        one.stage(dir.file("a.csv"), [](std::ostream& out) { out << "a"; });
        outer.adopt(one);
        CHECK(one.paths().empty());
        CHECK(outer.paths().size() == 2);
        OutputTransaction two;
        CHECK_THROWS_AS(two.stage_file(dir.file("G.h5"),
                                       [](const std::string& staged) {
                                           std::ofstream(staged) << "partial";
                                           throw InputError("G.h5", 0, "simulated failure");
                                       }),
                        InputError);
        // F.h5 staged again, by stream (a temporary of another name): two's file is dropped.
        two.stage(dir.file("F.h5"), [](std::ostream& out) { out << "again"; });
        CHECK_THROWS_AS(outer.adopt(two), Error);
        CHECK(two.paths().empty());
        CHECK(dir.entries() == 2);  // outer's two temporaries
    }                               // outer not committed: nothing is left
    CHECK(dir.entries() == 0);

    OutputTransaction outer;
    OutputTransaction one;
    one.stage_file(dir.file("F.h5"),
                   [](const std::string& staged) { std::ofstream(staged) << "h5"; });
    outer.adopt(one);
    outer.commit();
    CHECK(read_text(dir.file("F.h5")) == "h5");
    CHECK(dir.entries() == 1);
}

// ---- extensions -------------------------------------------------------------------------------

TEST_CASE("output: the matrix format comes from the extension") {
    CHECK(matrix_format_for("F.csv") == MatrixFormat::Csv);
    CHECK(matrix_format_for("dir.x/F.NPY") == MatrixFormat::Npy);
    CHECK(matrix_format_for("F.txt") == MatrixFormat::View3dText);
    // The library names its option field, never a command-line flag (the CLI passes "-o").
    CHECK(what_of([] { matrix_format_for("F.xyz"); }) ==
          "output: unknown output extension '.xyz' (use .csv, .npy, .txt or .dat)");
    CHECK(what_of([] { matrix_format_for("F.xyz", "-o"); }) ==
          "-o: unknown output extension '.xyz' (use .csv, .npy, .txt or .dat)");
    CHECK_THROWS_AS(matrix_format_for("F"), OptionError);
    CHECK_THROWS_AS(matrix_format_for("F.csv.gz"), OptionError);

    TempDir dir;
    CHECK_THROWS_AS(write_matrix(dir.file("F.xyz"), DenseMatrix::Identity(2, 2)), OptionError);
    CHECK(dir.entries() == 0);
}

// ---- CSV --------------------------------------------------------------------------------------

TEST_CASE("output: CSV is N lines of N %.17g values and round-trips bit for bit") {
    const DenseMatrix F = awkward_matrix(7);
    std::ostringstream out;
    write_csv_matrix(out, F);
    const std::string text = out.str();

    // Layout: no header, row i = line i, values as printf("%.17g").
    std::istringstream lines(text);
    std::string line;
    int i = 0;
    while (std::getline(lines, line)) {
        std::string expected;
        for (int j = 0; j < 7; ++j) {
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.17g", F(i, j));
            if (j) expected += ',';
            expected += buf;
        }
        CHECK(line == expected);
        ++i;
    }
    CHECK(i == 7);
    CHECK(text.back() == '\n');

    std::istringstream in(text);
    CHECK(bit_equal(read_csv_matrix(in, "F.csv"), F));

    TempDir dir;
    write_matrix(dir.file("F.csv"), F);
    CHECK(bit_equal(read_matrix(dir.file("F.csv")), F));
    CHECK(dir.entries() == 1);
}

TEST_CASE("output: CSV reader errors carry FILE:LINE") {
    auto read = [](const std::string& text) {
        return what_of([&] {
            std::istringstream in(text);
            read_csv_matrix(in, "m.csv");
        });
    };
    CHECK(read("1,2\n3,abc\n") == "m.csv:2: malformed number 'abc' in column 2");
    CHECK(read("1,2\n\n3\n") == "m.csv:3: 1 values, but line 1 has 2");
    CHECK(read("1,2\n3,nan\n") == "m.csv:2: non-finite value 'nan' in column 2");
    CHECK(read("1,,2\n") == "m.csv:1: empty value in column 2");
    CHECK(read("1,2x\n") == "m.csv:1: malformed number '2x' in column 2");
    CHECK(read("") == "m.csv: no matrix rows");
    // Tolerated: spaces, CRLF, '+', comments and blank lines.
    std::istringstream ok("# F\n 1 , +2\r\n\n3,4e-1\n");
    const DenseMatrix F = read_csv_matrix(ok, "ok.csv");
    CHECK(F.rows() == 2);
    CHECK(F(1, 1) == 0.4);
    CHECK(F(0, 1) == 2.0);

    TempDir dir;
    write_text(dir.file("r.csv"), "1,2,3\n4,5,6\n");
    CHECK(what_of([&] { read_matrix(dir.file("r.csv")); }).find("not square") != std::string::npos);
    CHECK(what_of([&] {
              read_matrix(dir.file("missing.csv"));
          }).find(dir.file("missing.csv") + ": cannot open") == 0);
    CHECK_THROWS_AS(read_matrix(dir.file("F.mat")), OptionError);
}

// ---- NPY --------------------------------------------------------------------------------------

TEST_CASE("output: NPY 1.0 header layout, byte by byte") {
    const std::string h = npy_header(3, 3);
    REQUIRE(h.size() == 128);  // the dict alone is 60 characters
    CHECK(h.substr(0, 6) == "\x93NUMPY");
    CHECK(h[6] == '\x01');
    CHECK(h[7] == '\x00');
    const std::size_t len = static_cast<unsigned char>(h[8]) |
                            (static_cast<std::size_t>(static_cast<unsigned char>(h[9])) << 8);
    CHECK(len == 128 - 10);
    const std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 3), }";
    CHECK(h.substr(10, dict.size()) == dict);
    CHECK(h.substr(10 + dict.size(), 128 - 10 - dict.size() - 1) ==
          std::string(128 - 10 - dict.size() - 1, ' '));
    CHECK(h.back() == '\n');

    // Longer shapes still pad to a multiple of 64 with the newline last.
    for (std::size_t n : {0UL, 1UL, 10UL, 12345UL, 123456789012UL}) {
        const std::string hn = npy_header(n, n);
        CHECK(hn.size() % 64 == 0);
        CHECK(hn.back() == '\n');
        CHECK(hn.find("'shape': (" + std::to_string(n) + ", " + std::to_string(n) + "), }") !=
              std::string::npos);
    }
}

TEST_CASE("output: NPY data is little-endian float64 in C order and round-trips") {
    DenseMatrix F(2, 3);
    F << 1.0, 2.0, 3.0, 4.0, 5.0, -0.5;
    std::ostringstream out;
    write_npy_matrix(out, F);
    const std::string bytes = out.str();
    REQUIRE(bytes.size() == 128 + 6 * 8);
    // F(0,1) = 2.0 = 0x4000000000000000: little-endian, so the last byte of the 8 is 0x40.
    CHECK(bytes.substr(128 + 8, 8) == std::string("\0\0\0\0\0\0\0\x40", 8));
    // F(1,2) = -0.5 = 0xBFE0000000000000.
    CHECK(bytes.substr(128 + 40, 8) == std::string("\0\0\0\0\0\0\xe0\xbf", 8));
    std::istringstream in(bytes);
    CHECK(bit_equal(read_npy_matrix(in, "F.npy"), F));

    const DenseMatrix G = awkward_matrix(9);
    TempDir dir;
    write_matrix(dir.file("G.npy"), G);
    CHECK(bit_equal(read_matrix(dir.file("G.npy")), G));
    CHECK(read_text(dir.file("G.npy")).size() == 128 + 81 * 8);
}

TEST_CASE("output: NPY reader handles Fortran order and rejects bad files") {
    // A hand-made Fortran-order 2x2 float64 array [[1, 2], [3, 4]]: stored 1, 3, 2, 4.
    std::string dict = "{'descr': '<f8', 'fortran_order': True, 'shape': (2, 2), }";
    dict.append(128 - 10 - dict.size() - 1, ' ');
    dict += '\n';
    std::string file = std::string("\x93NUMPY\x01\x00", 8);
    file += static_cast<char>(dict.size());
    file += '\0';
    file += dict;
    for (double v : {1.0, 3.0, 2.0, 4.0}) file.append(reinterpret_cast<const char*>(&v), 8);
    std::istringstream in(file);
    const DenseMatrix F = read_npy_matrix(in, "f.npy");
    CHECK(F(0, 1) == 2.0);
    CHECK(F(1, 0) == 3.0);

    auto read = [](const std::string& bytes) {
        return what_of([&] {
            std::istringstream s(bytes);
            read_npy_matrix(s, "x.npy");
        });
    };
    CHECK(read("PK\x03\x04 not npy") == "x.npy: not an NPY file (bad magic string)");
    CHECK(read(file.substr(0, file.size() - 3)).find("x.npy: truncated NPY data") == 0);
    CHECK(read(file + "x") == "x.npy: unexpected data after the NPY array");
    std::string int_file = file;
    int_file.replace(int_file.find("<f8"), 3, "<i8");
    CHECK(read(int_file) == "x.npy: unsupported NPY dtype '<i8' (expected '<f8')");
}

// ---- View3D text ------------------------------------------------------------------------------

TEST_CASE("output: View3D 3.2 text layout (SaveVF/SaveF0) and read back") {
    DenseMatrix F(2, 2);
    F << 0.0, 0.19982489569838746, 0.19982489569838746, 0.0;
    MatrixFileInfo info;
    info.areas = {1.0, 2.5};
    info.emissivities = {0.9, 0.85};
    std::ostringstream out;
    write_view3d_text(out, F, info);
    const std::string expected =
        "View3D 3.2 0 0 0 2            \n"  // header padded to 30 characters + '\n'
        "1 2.5\n"
        "0.000000 0.199825\n"
        "0.199825 0.000000\n"
        "0.900 0.850\n";
    CHECK(out.str() == expected);
    CHECK(out.str().find('\n') == 30);

    info.enclosure = true;
    info.emissivities.clear();
    std::ostringstream out2;
    write_view3d_text(out2, F, info);
    CHECK(out2.str().substr(0, 31) == "View3D 3.2 0 1 0 2            \n");
    CHECK(out2.str().find("\n0.900 0.900\n") != std::string::npos);

    std::istringstream in(expected);
    const View3dFile f = read_view3d_text(in, "vf.txt");
    CHECK(f.program == "View3D");
    CHECK(f.version == "3.2");
    CHECK(f.encl == 0);
    CHECK(f.areas[1] == 2.5);
    CHECK(f.F(0, 1) == 0.199825);
    CHECK(f.emissivities[1] == 0.85);

    std::istringstream bad("View3D 3.2 0 0 0 2\n1 2\n0 0.5\n0.5 x\n");
    CHECK(what_of([&] { read_view3d_text(bad, "vf.txt"); }) == "vf.txt:4: malformed number 'x'");
    std::istringstream short_file("View3D 3.2 0 0 0 2\n1 2\n0 0.5\n");
    CHECK(what_of([&] { read_view3d_text(short_file, "vf.txt"); }) ==
          "vf.txt:3: file ends after 4 of 8 values");

    TempDir dir;
    CHECK_THROWS_AS(write_matrix(dir.file("F.txt"), F), Error);  // no areas
    CHECK(dir.entries() == 0);
    FormFactors ff{F, {1.0, 2.5}, std::nullopt};
    write_matrix(dir.file("F.txt"), ff);
    CHECK(read_matrix(dir.file("F.txt"))(1, 0) == 0.199825);
}

TEST_CASE("output: the text of awkward values, byte for byte (.txt and .csv)") {
    // Ties rounded to even (0.0078125, 0.0625, 0.8125), signed zeros, values that round to a
    // signed zero, a value past the fast path (1e10), subnormals, 1e-300; expected texts are
    // C's printf conversions (%.6f, %.17g, %g, %.3f).
    DenseMatrix F(4, 4);
    F << 0.0078125, -0.0, -1e-9, 0.9999995,                                  //
        1e10, 2.5e-7, 0.5, 1.0000005,                                        //
        123456789.1234565, 1e-300, 0.19982489569838746, 3.0000000000000004,  //
        5e-324, -0.0625, 1e-5, 0.1;
    MatrixFileInfo info;
    info.areas = {1.0, 2.5, 1e-5, 123456789.0};
    info.emissivities = {0.9, 0.0625, 0.8125, 1.0};
    info.enclosure = true;
    std::ostringstream txt;
    write_view3d_text(txt, F, info);
    CHECK(txt.str() ==
          "View3D 3.2 0 1 0 4            \n"
          "1 2.5 1e-05 1.23457e+08\n"
          "0.007812 -0.000000 -0.000000 1.000000\n"
          "10000000000.000000 0.000000 0.500000 1.000001\n"
          "123456789.123456 0.000000 0.199825 3.000000\n"
          "0.000000 -0.062500 0.000010 0.100000\n"
          "0.900 0.062 0.812 1.000\n");
    std::ostringstream csv;
    write_csv_matrix(csv, F);
    CHECK(csv.str() ==
          "0.0078125,-0,-1.0000000000000001e-09,0.99999950000000004\n"
          "10000000000,2.4999999999999999e-07,0.5,1.0000005000000001\n"
          "123456789.12345649,1e-300,0.19982489569838746,3.0000000000000004\n"
          "4.9406564584124654e-324,-0.0625,1.0000000000000001e-05,0.10000000000000001\n");
}

TEST_CASE("output: numbers are printf's conversions on 300,000 values") {
    // The writers' formatter (core/text_numbers.h) against snprintf: values spread over every
    // exponent, random bit patterns, values rounded to 7 decimals (ties and near-ties of %.6f),
    // neighbours of powers of ten (where %.17g changes its exponent).
    std::mt19937_64 rng(2024);
    std::vector<double> values = {0.0,
                                  -0.0,
                                  0.0078125,
                                  0.0625,
                                  1e17,
                                  1e-5,
                                  9.9999999999999995e-5,
                                  1e16,
                                  1e-300,
                                  5e-324,
                                  1e300,
                                  0.5,
                                  999999.9999995,
                                  1e9,
                                  -1e9,
                                  999999999.9999995,
                                  0.1,
                                  1e-4,
                                  123456789012345678.0};
    for (int k = 0; k < 300000; ++k) {
        double x = 0;
        switch (k % 5) {
            case 0:
                x = std::uniform_real_distribution<double>(0, 1)(rng);
                break;
            case 1:
                x = std::bit_cast<double>(rng());
                break;
            case 2:
                x = std::ldexp(static_cast<double>(rng() >> 11), -static_cast<int>(rng() % 140));
                break;
            case 3:
                x = std::round(std::uniform_real_distribution<double>(-2, 2)(rng) * 1e7) / 1e7;
                break;
            default:
                x = std::nextafter(std::pow(10.0, static_cast<int>(rng() % 60) - 30),
                                   (rng() & 1) ? 0.0 : 1e300);
                break;
        }
        if (std::isfinite(x)) values.push_back(x);
    }
    std::size_t bad_g17 = 0, bad_f6 = 0, bad_f3 = 0, bad_g = 0;
    char expected[400], got[400];
    auto differs = [&](const char* end) {
        return std::string_view(got, static_cast<std::size_t>(end - got)) != expected;
    };
    for (const double x : values) {
        std::snprintf(expected, sizeof expected, "%.17g", x);
        if (differs(detail::print_g17(got, x)) && bad_g17++ < 3) MESSAGE("%.17g of " << expected);
        std::snprintf(expected, sizeof expected, "%.6f", x);
        if (differs(detail::print_fixed(got, x, 6)) && bad_f6++ < 3) MESSAGE("%.6f: " << expected);
        std::snprintf(expected, sizeof expected, "%.3f", x);
        if (differs(detail::print_fixed(got, x, 3)) && bad_f3++ < 3) MESSAGE("%.3f: " << expected);
        std::snprintf(expected, sizeof expected, "%g", x);
        if (differs(detail::print_g(got, x)) && bad_g++ < 3) MESSAGE("%g: " << expected);
    }
    CHECK(bad_g17 == 0);
    CHECK(bad_f6 == 0);
    CHECK(bad_f3 == 0);
    CHECK(bad_g == 0);
}

TEST_CASE("output: large text matrices (many blocks, formatted in parallel) are printf's text") {
    // 700 columns: a CSV row is ~16 kB, so the 2 MB blocks hold ~120 rows and the matrix takes
    // several blocks and waves; every line must still come out in order, value by value.
    const int n = 700;
    std::mt19937_64 rng(99);
    DenseMatrix F(n, n);
    for (Eigen::Index k = 0; k < F.size(); ++k)
        F.data()[k] = std::uniform_real_distribution<double>(0, 1)(rng) *
                      std::pow(10.0, -static_cast<int>(rng() % 9));
    MatrixFileInfo info;
    info.areas.assign(n, 0.25);
    std::ostringstream csv, txt;
    write_csv_matrix(csv, F);
    write_view3d_text(txt, F, info);
    std::string expected_csv, expected_txt = "View3D 3.2 0 0 0 700";
    expected_txt += std::string(30 - expected_txt.size(), ' ') + '\n';
    char buf[64];
    for (int k = 0; k < n; ++k) expected_txt += k ? " 0.25" : "0.25";
    expected_txt += '\n';
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            std::snprintf(buf, sizeof buf, j ? ",%.17g" : "%.17g", F(i, j));
            expected_csv += buf;
            std::snprintf(buf, sizeof buf, j ? " %.6f" : "%.6f", F(i, j));
            expected_txt += buf;
        }
        expected_csv += '\n';
        expected_txt += '\n';
    }
    for (int k = 0; k < n; ++k) expected_txt += k ? " 0.900" : "0.900";
    expected_txt += '\n';
    CHECK(csv.str().size() == expected_csv.size());
    CHECK(csv.str() == expected_csv);
    CHECK(txt.str() == expected_txt);
}

// ---- patch table and report -------------------------------------------------------------------

namespace {

Scene two_plate_scene() {
    Scene s;
    s.name = "hand-made";
    s.materials.push_back(Material{});
    Surface a;
    a.name = "bottom";
    a.polygon = Polygon{{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)}};
    Surface b;
    b.name = "top, flipped";
    b.polygon = Polygon{{Vec3(0, 0, 1), Vec3(0, 1, 1), Vec3(1, 1, 1), Vec3(1, 0, 1)}};
    Surface o;
    o.name = "blocker";
    o.obstruction = true;
    o.polygon = Polygon{{Vec3(5, 5, 5), Vec3(6, 5, 5), Vec3(6, 6, 5)}};
    s.surfaces = {a, b, o};
    for (int k = 0; k < 2; ++k) {
        Patch p;
        p.polygon = s.surfaces[static_cast<std::size_t>(k)].polygon;
        p.surface = k;
        p.area = 1.0;
        p.normal = Vec3(0, 0, k == 0 ? 1 : -1);
        p.centroid = Vec3(0.5, 0.5, k);
        s.patches.push_back(p);
    }
    s.warnings.push_back("just a test");
    return s;
}

}  // namespace

TEST_CASE("output: the patch table names each row") {
    const Scene s = two_plate_scene();
    std::ostringstream out;
    write_patch_table(out, s);
    CHECK(out.str() ==
          "patch,surface,surface_name,area,cx,cy,cz,nx,ny,nz\n"
          "0,0,bottom,1,0.5,0.5,0,0,0,1\n"
          "1,1,\"top, flipped\",1,0.5,0.5,1,0,0,-1\n");
}

TEST_CASE("output: the JSON report carries the run, the scene and the diagnostics") {
    const Scene s = two_plate_scene();
    FormFactors ff;
    ff.F.resize(2, 2);
    ff.F << 0.0, 0.2, 0.1, -0.01;  // reciprocity broken by a factor 2, one negative entry
    ff.areas = {1.0, 1.0};
    ReportContext ctx;
    ctx.method = "analytic";
    ctx.options = {{"subdivide", 1}, {"tolerance", 1e-10}};
    ctx.timings.add("load", 0.25);
    ctx.timings.add("compute", 1.0);
    ctx.timings.add("compute", 0.5);
    ctx.total_seconds = 2.0;
    ctx.threads = 2;
    ctx.details = {{"pairs", 4}};
    ctx.outputs = {{"matrix", "F.npy"}};
    const nlohmann::json r = make_report(s, ff, ctx);

    CHECK(r["N"] == 2);
    CHECK(r["method"] == "analytic");
    CHECK(r["formfactor_version"] == FF_VERSION);
    CHECK(r["timestamp"].get<std::string>().size() == 20);
    CHECK(r["options"]["tolerance"] == 1e-10);
    CHECK(r["threads"] == 2);
    CHECK(r["timings"]["load"] == 0.25);
    CHECK(r["timings"]["compute"] == 1.5);
    CHECK(r["timings"]["total"] == 2.0);
    CHECK(r["scene"]["name"] == "hand-made");
    CHECK(r["scene"]["surfaces"] == 2);
    CHECK(r["scene"]["obstructions"] == 1);
    CHECK(r["scene"]["patches"] == 2);
    CHECK(r["scene"]["total_area"] == 2.0);
    CHECK(r["scene"]["bounds"]["max"][0] == 6.0);
    CHECK(r["scene"]["warnings"][0] == "just a test");
    const auto& d = r["diagnostics"];
    CHECK(d["row_sum"]["min"].get<double>() == doctest::Approx(0.09));
    CHECK(d["row_sum"]["max"].get<double>() == doctest::Approx(0.2));
    CHECK(d["reciprocity"]["max_defect"].get<double>() == doctest::Approx(0.5));
    CHECK(d["reciprocity"]["i"] == 0);
    CHECK(d["reciprocity"]["j"] == 1);
    CHECK(d["negative_entries"] == 1);
    CHECK(d["entries_above_one"] == 0);
    CHECK(d["nonfinite_entries"] == 0);
    CHECK(d["max_abs_diagonal"].get<double>() == doctest::Approx(0.01));
    CHECK(d["standard_error"].is_null());  // an exact method gives none
    CHECK(r["details"]["pairs"] == 4);
    CHECK(r["outputs"]["matrix"] == "F.npy");

    ff.standard_error = DenseMatrix::Constant(2, 2, 0.5);
    (*ff.standard_error)(0, 1) = 2.5;
    const nlohmann::json se = make_report(s, ff, ctx)["diagnostics"]["standard_error"];
    CHECK(se["max"] == 2.5);
    CHECK(se["mean"] == 1.0);

    TempDir dir;
    write_json_file(dir.file("r.json"), r);
    const std::string text = read_text(dir.file("r.json"));
    CHECK(text.back() == '\n');
    CHECK(nlohmann::json::parse(text) == r);
}

TEST_CASE("output: the report has the sections the run set, and no others") {
    const Scene s = two_plate_scene();
    ReportContext ctx;
    ctx.method = "analytic (hierarchical operator)";
    ctx.storage = {{"kind", "hierarchical"}};
    ctx.solve = {{"kind", "radiosity"}};
    ctx.note = "a remark";
    const nlohmann::json r = make_report(s, 7, ctx);
    CHECK(r["N"] == 7);
    CHECK(r["storage"]["kind"] == "hierarchical");
    CHECK(r["solve"]["kind"] == "radiosity");
    CHECK(r["note"] == "a remark");
    for (const char* unset : {"diagnostics", "memory", "repair", "per_surface", "render", "rows"})
        CHECK_MESSAGE(!r.contains(unset), unset);

    // A block of rows: N counts every patch, "rows" is the block, the diagnostics its standard
    // errors alone (no row sums: the other rows are missing), and no memory section.
    FormFactors block;
    block.F = DenseMatrix::Constant(1, 2, 0.25);
    block.first_row = 1;
    block.areas = {1.0, 1.0};
    const nlohmann::json b = make_report(s, block, ReportContext{});
    CHECK(b["N"] == 2);
    CHECK(b["rows"] == nlohmann::json::array({1, 2}));
    CHECK(b["diagnostics"] == nlohmann::json{{"standard_error", nullptr}});
    CHECK(!b.contains("memory"));
}
