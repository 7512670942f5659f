// HDF5 output of sparse form factors (layout: formfactor/output/sparse_io.h, docs/sparse.md).
// Arrays are written in slices of at most kSlice elements (hyperslabs), so that no array is
// copied whole; the HDF5 library's own error printing is turned off while we write and every
// failure becomes an InputError naming the target.

#include "output/sparse_hdf5.h"

#include <fmt/format.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/matrix/memory.h"

namespace formfactor::detail {

namespace {

constexpr hsize_t kSlice = hsize_t(1) << 20;

// An HDF5 identifier closed by `close` when it goes out of scope.
class Handle {
  public:
    Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    ~Handle() {
        if (id_ >= 0) close_(id_);
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    hid_t get() const { return id_; }

  private:
    hid_t id_;
    herr_t (*close_)(hid_t);
};

// Silences HDF5's automatic error stack printing for the scope.
class QuietErrors {
  public:
    QuietErrors() {
        H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    }
    ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
    QuietErrors(const QuietErrors&) = delete;
    QuietErrors& operator=(const QuietErrors&) = delete;

  private:
    H5E_auto2_t func_ = nullptr;
    void* data_ = nullptr;
};

class Writer {
  public:
    // Objects are created without modification times, so that the same F makes the same bytes
    // (one process or many ranks, today or tomorrow).
    Writer(const std::string& target)
        : target_(target),
          dataset_props_(check(H5Pcreate(H5P_DATASET_CREATE), "properties"), H5Pclose),
          group_props_(check(H5Pcreate(H5P_GROUP_CREATE), "properties"), H5Pclose) {
        check(H5Pset_obj_track_times(dataset_props_.get(), false), "properties");
        check(H5Pset_obj_track_times(group_props_.get(), false), "properties");
    }
    hid_t group_props() const { return group_props_.get(); }

    hid_t check(hid_t id, const char* what) const {
        if (id < 0) fail(what);
        return id;
    }
    void check(herr_t status, const char* what) const {
        if (status < 0) fail(what);
    }
    [[noreturn]] void fail(const std::string& what) const {
        throw InputError(target_, 0, "HDF5 write failed: " + what + " (disk full?)");
    }

    // A dataset of `rows` × `cols` elements (cols 1: one dimension) of `type`, filled from
    // `data` (row-major) in slices of whole rows.
    void dataset(hid_t loc, const char* name, hid_t type, const void* data, hsize_t rows,
                 hsize_t cols = 1) const {
        const int rank = cols == 1 ? 1 : 2;
        const hsize_t dims[2] = {rows, cols};
        const Handle space(check(H5Screate_simple(rank, dims, nullptr), name), H5Sclose);
        const Handle set(check(H5Dcreate2(loc, name, type, space.get(), H5P_DEFAULT,
                                          dataset_props_.get(), H5P_DEFAULT),
                               name),
                         H5Dclose);
        const std::size_t elem = H5Tget_size(type);
        const hsize_t step = std::max<hsize_t>(1, kSlice / cols);
        for (hsize_t r = 0; r < rows; r += step) {
            const hsize_t count[2] = {std::min(step, rows - r), cols};
            const hsize_t start[2] = {r, 0};
            check(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, count, nullptr),
                  name);
            const Handle mem(check(H5Screate_simple(rank, count, nullptr), name), H5Sclose);
            const auto* p = static_cast<const char*>(data) + r * cols * elem;
            check(H5Dwrite(set.get(), type, mem.get(), space.get(), H5P_DEFAULT, p), name);
        }
    }

    template <class T>
    void attribute(hid_t loc, const char* name, hid_t type, const T& value) const {
        const Handle space(check(H5Screate(H5S_SCALAR), name), H5Sclose);
        const Handle a(
            check(H5Acreate2(loc, name, type, space.get(), H5P_DEFAULT, H5P_DEFAULT), name),
            H5Aclose);
        check(H5Awrite(a.get(), type, &value), name);
    }
    // A variable-length UTF-8 string attribute (h5py reads it as str).
    void attribute(hid_t loc, const char* name, const std::string& value) const {
        const Handle type(check(H5Tcopy(H5T_C_S1), name), H5Tclose);
        check(H5Tset_size(type.get(), H5T_VARIABLE), name);
        check(H5Tset_cset(type.get(), H5T_CSET_UTF8), name);
        const char* p = value.c_str();
        attribute(loc, name, type.get(), p);
    }

  private:
    std::string target_;  // first: check() names it
    Handle dataset_props_, group_props_;
};

}  // namespace

void write_sparse_hdf5(const std::string& file, const std::string& target,
                       const SparseFormFactors& F, const SparseFileInfo& info) {
    const QuietErrors quiet;
    const Writer w(target);
    const Handle f(H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (f.get() < 0) throw InputError(target, 0, "cannot create the HDF5 file");
    const hid_t root = f.get();
    const hsize_t n = F.n, nnz = F.nonzeros();
    w.dataset(root, "indptr", H5T_NATIVE_INT64, F.indptr.data(), n + 1);
    w.dataset(root, "indices", H5T_NATIVE_INT32, F.indices.data(), nnz);
    w.dataset(root, "data", H5T_NATIVE_DOUBLE, F.values.data(), nnz);
    if (F.standard_error)
        w.dataset(root, "standard_error", H5T_NATIVE_DOUBLE, F.standard_error->data(), nnz);
    w.dataset(root, "areas", H5T_NATIVE_DOUBLE, F.areas.data(), n);
    std::vector<double> per_row(F.n);
    for (std::size_t i = 0; i < F.n; ++i) per_row[i] = F.sky_factor(i);
    w.dataset(root, "sky_factor", H5T_NATIVE_DOUBLE, per_row.data(), n);
    w.dataset(root, "dropped", H5T_NATIVE_DOUBLE, F.dropped.data(), n);
    w.dataset(root, "computed_row_sum", H5T_NATIVE_DOUBLE, F.computed_row_sums.data(), n);
    if (info.patches) {
        const Handle g(
            w.check(H5Gcreate2(root, "patches", H5P_DEFAULT, w.group_props(), H5P_DEFAULT),
                    "patches"),
            H5Gclose);
        const std::vector<Patch>& p = *info.patches;
        std::vector<std::int32_t> surface(p.size());
        std::vector<double> xyz(3 * p.size());
        for (std::size_t i = 0; i < p.size(); ++i) surface[i] = p[i].surface;
        w.dataset(g.get(), "surface", H5T_NATIVE_INT32, surface.data(), n);
        for (std::size_t i = 0; i < p.size(); ++i)
            for (int c = 0; c < 3; ++c) xyz[3 * i + static_cast<std::size_t>(c)] = p[i].centroid[c];
        w.dataset(g.get(), "centroid", H5T_NATIVE_DOUBLE, xyz.data(), n, 3);
        for (std::size_t i = 0; i < p.size(); ++i)
            for (int c = 0; c < 3; ++c) xyz[3 * i + static_cast<std::size_t>(c)] = p[i].normal[c];
        w.dataset(g.get(), "normal", H5T_NATIVE_DOUBLE, xyz.data(), n, 3);
    }
    double total_area = 0.0, dropped_area = 0.0;
    for (std::size_t i = 0; i < F.n; ++i) {
        total_area += F.areas[i];
        dropped_area += F.areas[i] * F.dropped[i];
    }
    const std::uint64_t n64 = F.n, nnz64 = F.nonzeros();
    const std::int32_t version = 1;
    w.attribute(root, "format", "formfactor sparse form factors (CSR)");
    w.attribute(root, "format_version", H5T_NATIVE_INT32, version);
    w.attribute(root, "N", H5T_NATIVE_UINT64, n64);
    w.attribute(root, "nonzeros", H5T_NATIVE_UINT64, nnz64);
    w.attribute(root, "threshold", H5T_NATIVE_DOUBLE, F.threshold);
    w.attribute(root, "dropped_mass", H5T_NATIVE_DOUBLE,
                total_area > 0.0 ? dropped_area / total_area : 0.0);
    w.attribute(root, "direction",
                "data[k] = F[i, indices[k]] for indptr[i] <= k < indptr[i+1]: the fraction of "
                "the energy leaving patch i that reaches patch indices[k] (0-based)");
    w.attribute(root, "scene", info.scene);
    w.attribute(root, "method", info.method);
    w.attribute(root, "repair", info.repair);
    w.attribute(root, "program", std::string("formfactor ") + FF_VERSION);
    w.check(H5Fflush(root, H5F_SCOPE_GLOBAL), "flush");
}

}  // namespace formfactor::detail

namespace formfactor::detail {

namespace {

// Reads whole one-dimensional datasets of a file opened for reading, every failure an
// InputError naming the file.
class Reader {
  public:
    explicit Reader(const std::string& path) : path_(path) {}

    [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, 0, what); }

    bool has(hid_t loc, const char* name) const { return H5Lexists(loc, name, H5P_DEFAULT) > 0; }

    // The length of the one-dimensional dataset `name`.
    hsize_t length(hid_t loc, const char* name) const {
        if (!has(loc, name)) fail(std::string("no dataset '") + name + "'");
        const Handle set(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose);
        if (set.get() < 0) fail(std::string("cannot open dataset '") + name + "'");
        const Handle space(H5Dget_space(set.get()), H5Sclose);
        if (space.get() < 0 || H5Sget_simple_extent_ndims(space.get()) != 1)
            fail(std::string("dataset '") + name + "' is not one-dimensional");
        hsize_t dims[1] = {0};
        H5Sget_simple_extent_dims(space.get(), dims, nullptr);
        return dims[0];
    }

    // Dataset `name` of `count` elements, converted to `type` (T's native type).
    template <class T>
    std::vector<T> read(hid_t loc, const char* name, hid_t type, hsize_t count) const {
        if (length(loc, name) != count)
            fail(fmt::format("dataset '{}' has {} elements, expected {}", name, length(loc, name),
                             count));
        const Handle set(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose);
        std::vector<T> v(static_cast<std::size_t>(count));
        if (count > 0 && H5Dread(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
            fail(std::string("cannot read dataset '") + name + "' as numbers of its kind");
        return v;
    }

    std::uint64_t attribute_u64(hid_t loc, const char* name) const {
        if (H5Aexists(loc, name) <= 0) fail(std::string("no attribute '") + name + "'");
        const Handle a(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
        std::uint64_t v = 0;
        if (a.get() < 0 || H5Aread(a.get(), H5T_NATIVE_UINT64, &v) < 0)
            fail(std::string("cannot read attribute '") + name + "' as a whole number");
        return v;
    }

  private:
    std::string path_;
};

}  // namespace

SparseFormFactors read_sparse_hdf5(const std::string& path) {
    const QuietErrors quiet;
    const Reader r(path);
    if (!std::filesystem::exists(path)) r.fail("cannot open file");
    if (H5Fis_hdf5(path.c_str()) <= 0) r.fail("not an HDF5 file (or it cannot be read)");
    const Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (f.get() < 0) r.fail("cannot open the HDF5 file");
    const hid_t root = f.get();
    const std::uint64_t n = r.attribute_u64(root, "N");
    if (n > std::uint64_t(INT32_MAX)) r.fail(fmt::format("N = {}: more than 2^31 - 1 patches", n));
    const hsize_t nnz = r.length(root, "data");
    const double bytes = sparse_matrix_bytes(double(n), double(nnz), r.has(root, "standard_error"));
    if (const double available = available_memory(); available > 0.0 && bytes > available)
        r.fail(fmt::format("{} entries need {:.3g} GB, more than the {:.3g} GB available", nnz,
                           bytes / 1e9, available / 1e9));
    SparseFormFactors F;
    F.n = static_cast<std::size_t>(n);
    F.indptr = r.read<std::int64_t>(root, "indptr", H5T_NATIVE_INT64, n + 1);
    F.indices = r.read<std::int32_t>(root, "indices", H5T_NATIVE_INT32, nnz);
    F.values = r.read<double>(root, "data", H5T_NATIVE_DOUBLE, nnz);
    F.areas = r.read<double>(root, "areas", H5T_NATIVE_DOUBLE, n);
    if (r.has(root, "standard_error")) {
        F.standard_error = r.read<double>(root, "standard_error", H5T_NATIVE_DOUBLE, nnz);
        for (double e : *F.standard_error)
            if (!(e >= 0.0) || !std::isfinite(e))
                r.fail("a standard error is not a finite number >= 0");
    }
    F.computed_row_sums.resize(F.n);
    F.dropped.assign(F.n, 0.0);
    try {
        F.check();
    } catch (const Error& e) {
        r.fail(e.what());
    }
    for (double a : F.areas)
        if (!(a > 0.0) || !std::isfinite(a)) r.fail("an area is not a finite positive number");
    if (r.has(root, "computed_row_sum") && r.has(root, "dropped")) {
        F.computed_row_sums = r.read<double>(root, "computed_row_sum", H5T_NATIVE_DOUBLE, n);
        F.dropped = r.read<double>(root, "dropped", H5T_NATIVE_DOUBLE, n);
        for (std::size_t i = 0; i < F.n; ++i)
            if (!std::isfinite(F.computed_row_sums[i]) || !std::isfinite(F.dropped[i]))
                r.fail(fmt::format("row {}: computed_row_sum or dropped is not finite", i));
    } else {
        for (std::size_t i = 0; i < F.n; ++i) F.computed_row_sums[i] = F.row_sum(i);
    }
    return F;
}

}  // namespace formfactor::detail
