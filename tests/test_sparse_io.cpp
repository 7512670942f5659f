// Sparse matrix files: Matrix Market read back by a parser of its own, HDF5 read back with the
// HDF5 C API; both atomic.

#include <doctest/doctest.h>
#include <hdf5.h>

#include <chrono>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/pipeline_sparse.h"
#include "formfactor/scene/city.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::TempDir;

namespace {

struct Mtx {
    std::vector<std::string> comments;
    std::string banner;
    std::size_t rows = 0, cols = 0, entries = 0;
    std::vector<std::size_t> i, j;  // 1-based, as in the file
    std::vector<double> v;
};

Mtx read_mtx(const std::string& path) {
    std::ifstream in(path);
    REQUIRE(in);
    Mtx m;
    std::string line;
    REQUIRE(std::getline(in, m.banner));
    while (std::getline(in, line) && !line.empty() && line[0] == '%') m.comments.push_back(line);
    std::istringstream size(line);
    const bool read = static_cast<bool>(size >> m.rows >> m.cols >> m.entries);
    REQUIRE(read);
    std::size_t a = 0, b = 0;
    std::string value;
    while (in >> a >> b >> value) {
        m.i.push_back(a);
        m.j.push_back(b);
        m.v.push_back(std::stod(value));
    }
    return m;
}

SparseComputeResult city_sparse(double threshold) {
    SparseOptions sparse;
    sparse.threshold = threshold;
    sparse.block_rows = 10;  // three blocks: cheap under the sanitizers, still several blocks
    return compute_sparse_form_factors(city_scene(1), {}, sparse);
}

template <class T>
std::vector<T> read_dataset(hid_t file, const char* name, hid_t type) {
    const hid_t set = H5Dopen2(file, name, H5P_DEFAULT);
    REQUIRE(set >= 0);
    const hid_t space = H5Dget_space(set);
    const hssize_t count = H5Sget_simple_extent_npoints(space);
    std::vector<T> out(static_cast<std::size_t>(count));
    CHECK(H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) >= 0);
    H5Sclose(space);
    H5Dclose(set);
    return out;
}

template <class T>
T read_attribute(hid_t file, const char* name, hid_t type) {
    T value{};
    const hid_t a = H5Aopen(file, name, H5P_DEFAULT);
    REQUIRE(a >= 0);
    CHECK(H5Aread(a, type, &value) >= 0);
    H5Aclose(a);
    return value;
}

}  // namespace

TEST_CASE("sparse io: Matrix Market round trip is exact") {
    const SparseComputeResult r = city_sparse(1e-4);
    const SparseFormFactors& F = r.form_factors;
    const TempDir dir;
    const std::string path = dir.file("F.mtx");
    SparseFileInfo info;
    info.scene = "city-1";
    info.method = "analytic";
    write_sparse_matrix(path, F, info);
    CHECK(dir.entries() == 1);  // no temporary left behind
    const Mtx m = read_mtx(path);
    CHECK(m.banner == "%%MatrixMarket matrix coordinate real general");
    bool scene_line = false, direction_line = false;
    for (const std::string& c : m.comments) {
        scene_line = scene_line || c == "% scene: city-1";
        direction_line = direction_line || c.find("row i = from patch i") != std::string::npos;
    }
    CHECK(scene_line);
    CHECK(direction_line);
    CHECK(m.rows == F.n);
    CHECK(m.cols == F.n);
    REQUIRE(m.entries == F.nonzeros());
    REQUIRE(m.v.size() == F.nonzeros());
    std::size_t k = 0;
    for (std::size_t i = 0; i < F.n; ++i)
        for (auto e = F.indptr[i]; e < F.indptr[i + 1]; ++e, ++k) {
            CHECK(m.i[k] == i + 1);
            CHECK(m.j[k] == std::size_t(F.indices[std::size_t(e)]) + 1);
            CHECK(m.v[k] == F.values[std::size_t(e)]);  // %.17g reads back bit for bit
        }
}

TEST_CASE("sparse io: HDF5 layout read back with the C API") {
    const SparseComputeResult r = city_sparse(2e-2);
    const SparseFormFactors& F = r.form_factors;
    const Scene scene = city_scene(1);
    const TempDir dir;
    const std::string path = dir.file("F.h5");
    SparseFileInfo info;
    info.scene = "city-1";
    info.method = "analytic";
    info.patches = &scene.patches;
    write_sparse_matrix(path, F, info);
    CHECK(dir.entries() == 1);
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(file >= 0);
    CHECK(read_dataset<std::int64_t>(file, "indptr", H5T_NATIVE_INT64) == F.indptr);
    CHECK(read_dataset<std::int32_t>(file, "indices", H5T_NATIVE_INT32) == F.indices);
    CHECK(read_dataset<double>(file, "data", H5T_NATIVE_DOUBLE) == F.values);
    CHECK(read_dataset<double>(file, "areas", H5T_NATIVE_DOUBLE) == F.areas);
    CHECK(read_dataset<double>(file, "dropped", H5T_NATIVE_DOUBLE) == F.dropped);
    const auto sky = read_dataset<double>(file, "sky_factor", H5T_NATIVE_DOUBLE);
    REQUIRE(sky.size() == F.n);
    for (std::size_t i = 0; i < F.n; ++i) CHECK(sky[i] == F.sky_factor(i));
    CHECK(H5Lexists(file, "standard_error", H5P_DEFAULT) == 0);
    const auto surface = read_dataset<std::int32_t>(file, "patches/surface", H5T_NATIVE_INT32);
    const auto centroid = read_dataset<double>(file, "patches/centroid", H5T_NATIVE_DOUBLE);
    const auto normal = read_dataset<double>(file, "patches/normal", H5T_NATIVE_DOUBLE);
    REQUIRE(centroid.size() == 3 * F.n);
    REQUIRE(normal.size() == 3 * F.n);
    for (std::size_t i = 0; i < F.n; ++i) {
        CHECK(surface[i] == scene.patches[i].surface);
        for (int c = 0; c < 3; ++c) {
            CHECK(centroid[3 * i + std::size_t(c)] == scene.patches[i].centroid[c]);
            CHECK(normal[3 * i + std::size_t(c)] == scene.patches[i].normal[c]);
        }
    }
    CHECK(read_attribute<std::uint64_t>(file, "N", H5T_NATIVE_UINT64) == F.n);
    CHECK(read_attribute<std::uint64_t>(file, "nonzeros", H5T_NATIVE_UINT64) == F.nonzeros());
    CHECK(read_attribute<double>(file, "threshold", H5T_NATIVE_DOUBLE) == 2e-2);
    CHECK(read_attribute<double>(file, "dropped_mass", H5T_NATIVE_DOUBLE) > 0.0);
    {
        const hid_t a = H5Aopen(file, "scene", H5P_DEFAULT);
        REQUIRE(a >= 0);
        const hid_t type = H5Aget_type(a);
        char* s = nullptr;
        CHECK(H5Aread(a, type, &s) >= 0);
        CHECK(std::string(s) == "city-1");
        H5free_memory(s);
        H5Tclose(type);
        H5Aclose(a);
    }
    H5Fclose(file);
}

TEST_CASE("sparse io: bad extension or directory writes nothing") {
    const SparseComputeResult r = city_sparse(1e-3);
    const TempDir dir;
    CHECK_THROWS_AS(write_sparse_matrix(dir.file("F.csv"), r.form_factors), OptionError);
    CHECK_THROWS_AS(write_sparse_matrix(dir.file("no/F.h5"), r.form_factors), InputError);
    CHECK_THROWS_AS(write_sparse_matrix(dir.file("no/F.mtx"), r.form_factors), InputError);
    const std::vector<Patch> wrong(3);
    SparseFileInfo info;
    info.patches = &wrong;
    CHECK_THROWS_AS(write_sparse_matrix(dir.file("F.h5"), r.form_factors, info), Error);
    CHECK(dir.entries() == 0);
    CHECK(is_sparse_matrix_path("a/F.MTX"));
    CHECK(is_sparse_matrix_path("F.h5"));
    CHECK_FALSE(is_sparse_matrix_path("F.npy"));
}

TEST_CASE("sparse io: the same F written to .h5 a second later has the same bytes") {
    // HDF5 stamps objects with their times unless told not to (seconds).
    const SparseComputeResult r = city_sparse(1e-4);
    const Scene scene = city_scene(1);
    const TempDir dir;
    SparseFileInfo info;
    info.patches = &scene.patches;  // the group of patch arrays too
    write_sparse_matrix(dir.file("A.h5"), r.form_factors, info);
    std::this_thread::sleep_for(std::chrono::milliseconds(1100));
    write_sparse_matrix(dir.file("B.h5"), r.form_factors, info);
    auto bytes = [&](const char* name) {
        std::ifstream in(dir.file(name), std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    REQUIRE(!bytes("A.h5").empty());
    CHECK(bytes("A.h5") == bytes("B.h5"));
}

TEST_CASE("sparse io: read_sparse_matrix gives back what the writers wrote, bit for bit") {
    const SparseComputeResult r = city_sparse(1e-4);
    const SparseFormFactors& F = r.form_factors;
    const Scene scene = city_scene(1);
    const TempDir dir;
    SparseFileInfo info;
    info.patches = &scene.patches;
    write_sparse_matrix(dir.file("F.mtx"), F, info);
    write_sparse_matrix(dir.file("F.h5"), F, info);
    for (const char* name : {"F.mtx", "F.h5"}) {
        CAPTURE(name);
        const SparseFormFactors G = read_sparse_matrix(dir.file(name));
        CHECK(G.n == F.n);
        CHECK(G.indptr == F.indptr);
        CHECK(G.indices == F.indices);
        CHECK(G.values == F.values);
        if (std::string(name) == "F.h5") {
            CHECK(G.areas == F.areas);
            CHECK(G.computed_row_sums == F.computed_row_sums);
            CHECK(G.dropped == F.dropped);
        } else {
            CHECK(G.areas.empty());  // a .mtx file holds no areas: the scene gives them
            for (std::size_t i = 0; i < G.n; ++i) CHECK(G.dropped[i] == 0.0);
        }
        // Made ready for the scene: the areas are the scene's.
        const SparseComputeResult ready = sparse_form_factors_from_matrix(scene, G);
        CHECK(ready.form_factors.areas == F.areas);
    }
    // Another scene, or another subdivision: refused, naming the file.
    Scene other = city_scene(1);
    other.patches.pop_back();
    CHECK_THROWS_AS(sparse_form_factors_from_matrix(other, read_sparse_matrix(dir.file("F.h5")), {},
                                                    dir.file("F.h5")),
                    InputError);
    Scene scaled = city_scene(1);
    for (Patch& p : scaled.patches) p.area *= 4.0;
    CHECK_THROWS_AS(sparse_form_factors_from_matrix(scaled, read_sparse_matrix(dir.file("F.h5")),
                                                    {}, dir.file("F.h5")),
                    InputError);
}

TEST_CASE("sparse io: Matrix Market input that is not a form-factor matrix names its line") {
    struct Case {
        const char* text;
        int line;
        const char* says;
    };
    const char* banner = "%%MatrixMarket matrix coordinate real general\n";
    for (const Case& c : {
             Case{"", 1, "empty"},
             Case{"%%MatrixMarket matrix array real general\n2 2\n", 1, "coordinate"},
             Case{"%%MatrixMarket matrix coordinate complex general\n", 1, "real"},
             Case{"%%MatrixMarket matrix coordinate real symmetric\n", 1, "symmetric"},
             Case{"%%MatrixMarket matrix coordinate pattern general\n", 1, "real"},
             Case{"hello\n", 1, "not a Matrix Market file"},
             Case{"B% c\n2 3 1\n", 3, "square"},
             Case{"B2 2\n", 2, "size line"},
             Case{"B2 2 1\n1 3 0.5\n", 3, "outside"},
             Case{"B2 2 1\n0 1 0.5\n", 3, "outside"},
             Case{"B2 2 1\n1 2 nan\n", 3, "finite"},
             Case{"B2 2 1\n1 2 0.5 7\n", 3, "entry"},
             Case{"B2 2 1\n1 2 x\n", 3, "entry"},
             Case{"B2 2 2\n1 2 0.5\n", 3, "1 entries, the size line says 2"},
             Case{"B2 2 1\n1 2 0.5\n2 1 0.5\n", 4, "more entries"},
             Case{"B2 2 2\n1 2 0.5\n1 2 0.25\n", 0, "given twice"},
             Case{"B2 2 5\n", 2, "5 entries in a 2 x 2"},
             Case{"B3000000000 3000000000 1\n", 2, "2^31"},
         }) {
        std::string text = c.text;
        if (!text.empty() && text[0] == 'B') text = banner + text.substr(1);
        CAPTURE(text);
        std::istringstream in(text);
        try {
            read_matrix_market(in, "F.mtx");
            FAIL("accepted");
        } catch (const InputError& e) {
            const std::string what = e.what();
            CAPTURE(what);
            CHECK(what.find(c.says) != std::string::npos);
            CHECK(e.file() == "F.mtx");
            CHECK(e.line() == c.line);
        }
    }
    // Integer values, comments and blank lines between entries, any order: accepted.
    std::istringstream in(std::string(banner) + "% c\n3 3 3\n\n3 1 1\n% mid\n1 2 0.5\n1 3 0.25\n");
    const SparseFormFactors F = read_matrix_market(in, "F.mtx");
    CHECK(F.indptr == std::vector<std::int64_t>{0, 2, 2, 3});
    CHECK(F.indices == std::vector<std::int32_t>{1, 2, 0});
    CHECK(F.values == std::vector<double>{0.5, 0.25, 1.0});
    CHECK_THROWS_AS(read_sparse_matrix("F.csv"), OptionError);
}
