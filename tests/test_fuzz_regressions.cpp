// Every input that once made a fuzz target (fuzz/) crash, hang, allocate without bound or break
// an invariant, run through the same harness: tests/data/fuzz_regressions/<target>/<file>. Plus
// the specific answers those inputs must get.

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "fuzz/harness.h"

using namespace formfactor;
namespace fs = std::filesystem;

namespace {

std::string read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

bool run_bytes(fuzz::Target target, const std::string& bytes) {
    return fuzz::run(target, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

// An NPY 1.0 file whose header says `shape` and which holds `data_bytes` bytes of data.
std::string npy_with_shape(const std::string& shape, std::size_t data_bytes) {
    std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': " + shape + ", }";
    while ((dict.size() + 11) % 64 != 0) dict += ' ';
    dict += '\n';
    std::string npy = std::string("\x93NUMPY\x01\x00", 8);
    npy += static_cast<char>(dict.size() & 0xff);
    npy += static_cast<char>(dict.size() >> 8);
    return npy + dict + std::string(data_bytes, '\0');
}

}  // namespace

TEST_CASE("fuzz regressions: every saved input gets a clean answer") {
    const fs::path root = fs::path(FF_TEST_DATA_DIR) / "fuzz_regressions";
    int files = 0;
    for (const auto& t : fuzz::kTargets) {
        const fs::path dir = root / t.name;
        if (!fs::is_directory(dir)) continue;
        for (const auto& e : fs::directory_iterator(dir)) {
            INFO(t.name << ": " << e.path().filename().string());
            CHECK_NOTHROW(run_bytes(t.target, read_bytes(e.path())));
            ++files;
        }
    }
    MESSAGE(files << " regression inputs");
}

TEST_CASE("fuzz regressions: the seeds of every target are accepted") {
    // The harness itself: what our writers write, the readers read (fuzz/make_seeds.cpp makes
    // the same kind of inputs).
    std::ostringstream csv, npy;
    DenseMatrix F(2, 2);
    F << 0, 0.5, 0.25, 0;
    write_csv_matrix(csv, F);
    write_npy_matrix(npy, F);
    CHECK(run_bytes(fuzz::Target::matrix_csv, csv.str()));
    CHECK(run_bytes(fuzz::Target::matrix_npy, npy.str()));
    CHECK(run_bytes(fuzz::Target::obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
    CHECK(run_bytes(fuzz::Target::obj,
                    "mtllib fuzz.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n#%mtl\n"
                    "newmtl a\nKd 0.5\n"));
    CHECK(run_bytes(fuzz::Target::properties, "surface,emissivity\nx0,0.5\n"));
    CHECK(
        run_bytes(fuzz::Target::solution, "patch,radiosity_r,radiosity_g,radiosity_b\n0,1,2,3\n"));
    CHECK_FALSE(run_bytes(fuzz::Target::vs3, "T too few numbers\nV 1 0 0\n"));
    CHECK(run_bytes(fuzz::Target::points, "x,y,z,nx,ny,nz\n0,0,0,0,0,2\n"));
    CHECK_FALSE(run_bytes(fuzz::Target::points, "0,0,0,0,0,0\n"));
    std::ostringstream dat;
    write_elmer_view_factors(dat, F);
    CHECK(run_bytes(fuzz::Target::matrix_dat, dat.str()));
    CHECK_FALSE(run_bytes(fuzz::Target::matrix_dat, "1\n1 2 0.5\n"));
    CHECK(run_bytes(fuzz::Target::idf,
                    "Zone,Z;GlobalGeometryRules,UpperLeftCorner,Counterclockwise,World;\n"
                    "Floor:Detailed,F,C,Z,,Ground,,NoSun,NoWind,,3,0,0,0,0,1,0,1,0,0;\n"
                    "Wall:Detailed,W,C,Z,,Outdoors,,SunExposed,WindExposed,,3,0,0,0,1,0,0,0,0,1;"));
    CHECK_FALSE(run_bytes(fuzz::Target::idf, "Zone,Z;Floor:Detailed,F,C,Z,,Ground"));
    const std::string epjson =
        R"({"Zone": {"Z": {}}, "GlobalGeometryRules": {"G": {"starting_vertex_position": )"
        R"("UpperLeftCorner", "vertex_entry_direction": "Counterclockwise", "coordinate_system": )"
        R"("World"}}, "BuildingSurface:Detailed": {"F": {"surface_type": "Floor", "zone_name": )"
        R"("Z", "vertices": [{"vertex_x_coordinate": 0, "vertex_y_coordinate": 0, )"
        R"("vertex_z_coordinate": 0}, {"vertex_x_coordinate": 0, "vertex_y_coordinate": 1, )"
        R"("vertex_z_coordinate": 0}, {"vertex_x_coordinate": 1, "vertex_y_coordinate": 0, )"
        R"("vertex_z_coordinate": 0}]}}})";
    CHECK(run_bytes(fuzz::Target::epjson, epjson));
    // Cut short, and a model the IDF grammar would read: both refused by the JSON reader.
    CHECK_FALSE(run_bytes(fuzz::Target::epjson, epjson.substr(0, epjson.size() / 2)));
    CHECK_FALSE(run_bytes(fuzz::Target::epjson,
                          "Zone,Z;Floor:Detailed,F,C,Z,,Ground,,,,,3,0,0,0,"
                          "0,1,0,1,0,0;"));
    CHECK(run_bytes(fuzz::Target::msh,
                    "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n1 0 0 0\n"
                    "2 1 0 0\n3 0 1 0\n$EndNodes\n$Elements\n1\n1 2 0 1 2 3\n"
                    "$EndElements\n"));
    CHECK_FALSE(run_bytes(fuzz::Target::msh, "$MeshFormat\n4.1 1 8\n\x01"));
    CHECK(run_bytes(fuzz::Target::mesh,
                    std::string(1, '\2') + "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
    CHECK_FALSE(run_bytes(fuzz::Target::mesh, std::string(1, '\2') + "OFF\n3 1 0\n0 0 0\n"));
}

TEST_CASE("fuzz regressions: an NPY header claiming 10^12 values is an input error") {
    const std::string npy = npy_with_shape("(1000000, 1000000)", 64);
    std::istringstream in(npy);
    CHECK_THROWS_WITH_AS(read_npy_matrix(in, "big.npy"), doctest::Contains("truncated NPY data"),
                         InputError);
    CHECK_FALSE(run_bytes(fuzz::Target::matrix_npy, npy));
    // Just under the 2^40 limit on values and far above memory: the same answer, at once.
    std::istringstream in2(npy_with_shape("(1048576, 1048575)", 0));
    CHECK_THROWS_AS(read_npy_matrix(in2, "big.npy"), InputError);
}

TEST_CASE("fuzz regressions: an NPY shape with a zero or a huge side is an input error") {
    // CI's fuzz run: (0, 2^62) made an empty matrix whose 2^62 columns allFinite() visited (a
    // hang); (2^64-1, 0) and (2^63, 0) became negative Eigen sizes (an assertion).
    for (const std::string shape :
         {"(0, 4611686018427387904)", "(18446744073709551615, 0)", "(0, 18446744073709551615)",
          "(9223372036854775808, 0)", "(0, 0)", "(0, 3)", "(3, 0)"}) {
        INFO(shape);
        std::istringstream in(npy_with_shape(shape, 0));
        CHECK_THROWS_WITH_AS(read_npy_matrix(in, "e.npy"), doctest::Contains("empty NPY array"),
                             InputError);
        CHECK_FALSE(run_bytes(fuzz::Target::matrix_npy, npy_with_shape(shape, 0)));
    }
    for (const std::string shape : {"(4294967296, 1)", "(1, 4294967296)", "(2147483649, 2)"}) {
        INFO(shape);
        std::istringstream in(npy_with_shape(shape, 16));
        CHECK_THROWS_WITH_AS(read_npy_matrix(in, "e.npy"), doctest::Contains("too large"),
                             InputError);
    }
}

TEST_CASE("fuzz regressions: a View3D header claiming 10^9 surfaces is an input error") {
    std::istringstream in1("View3D 3.2 0 0 0 1000000000\n1 2 3\n");
    CHECK_THROWS_WITH_AS(read_view3d_text(in1, "big.txt"), doctest::Contains("file ends after"),
                         InputError);
    std::istringstream in2("View3D 3.2 0 0 0 4000000000\n");
    CHECK_THROWS_WITH_AS(read_view3d_text(in2, "big.txt"), doctest::Contains("too many"),
                         InputError);
}

TEST_CASE("fuzz regressions: a View3D text matrix with NaN or +-1 is refused") {
    std::istringstream in1("View3D 3.2 0 0 0 1\n1\nnan\n0.9\n");
    CHECK_THROWS_WITH_AS(read_view3d_text(in1, "nan.txt"), doctest::Contains("non-finite"),
                         InputError);
    std::istringstream in2("View3D 3.2 0 0 0 1\n1\n+-1\n0.9\n");
    CHECK_THROWS_WITH_AS(read_view3d_text(in2, "sign.txt"), doctest::Contains("malformed"),
                         InputError);
}

TEST_CASE(
    "fuzz regressions: damaged PLY, OFF and glTF files Open Asset Import looped, leaked, crashed "
    "or ran out of memory on are refused") {
    // A header cut short or with `end_header` misspelled (an endless loop in Open Asset Import
    // 5.2.5), an ASCII word that is not a number (a leak), a binary header with a damaged
    // `end_header` (a crash), binary data cut short (read as if it were there); a damaged PLY
    // named .gltf or .glb (which assimp handed to its PLY reader when its glTF readers did not
    // recognise it: the same endless loop); an OFF file that declares 10^11 faces in 146 bytes
    // (15 GB asked for before a line was read); a binary glTF 1 header declaring a scene of
    // 1.85 GB in 33 bytes (allocated before it was read); a PLY element named 4294967295,
    // which assimp read as its count (96 GB asked for); an OFF file whose only face has 0
    // vertices (assimp dropped it, and its check of the mesh left without faces crashed).
    const fs::path dir = fs::path(FF_TEST_DATA_DIR) / "fuzz_regressions" / "mesh";
    int files = 0;
    for (const auto& e : fs::directory_iterator(dir)) {
        INFO(e.path().filename().string());
        CHECK_FALSE(run_bytes(fuzz::Target::mesh, read_bytes(e.path())));
        ++files;
    }
    CHECK(files == 11);
}
