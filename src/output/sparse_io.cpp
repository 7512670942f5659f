// Sparse matrix files: Matrix Market coordinate text, and HDF5 (sparse_hdf5.cpp), both written
// to a temporary name and renamed into place.

#include "formfactor/output/sparse_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <ostream>
#include <system_error>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "output/extension.h"
#include "output/sparse_hdf5.h"

namespace formfactor {

using detail::lower_extension;

namespace {

// One line of free text for a header comment (no line breaks).
std::string one_line(std::string s) {
    std::replace(s.begin(), s.end(), '\n', ' ');
    std::replace(s.begin(), s.end(), '\r', ' ');
    return s;
}

}  // namespace

bool is_sparse_matrix_path(const std::string& path) {
    const std::string ext = lower_extension(path);
    return ext == ".mtx" || ext == ".h5";
}

SparseMatrixFormat sparse_matrix_format_for(const std::string& path, const std::string& option) {
    const std::string ext = lower_extension(path);
    if (ext == ".mtx") return SparseMatrixFormat::MatrixMarket;
    if (ext == ".h5") return SparseMatrixFormat::Hdf5;
    throw OptionError(option, "unknown sparse output extension '" + ext + "' (use .mtx or .h5)");
}

void write_matrix_market(std::ostream& out, const SparseFormFactors& F,
                         const SparseFileInfo& info) {
    fmt::memory_buffer buf;
    const auto it = std::back_inserter(buf);
    fmt::format_to(it, "%%MatrixMarket matrix coordinate real general\n");
    fmt::format_to(it, "% formfactor {}: radiative form factors (view factors)\n", FF_VERSION);
    fmt::format_to(
        it,
        "% entry (i, j) = F_ij, the fraction of the energy leaving patch i diffusely that reaches "
        "patch j directly (row i = from patch i)\n");
    fmt::format_to(
        it,
        "% indices are 1-based here (Matrix Market); patch i of the scene's 0-based order is row "
        "i + 1\n");
    if (!info.scene.empty()) fmt::format_to(it, "% scene: {}\n", one_line(info.scene));
    if (!info.method.empty()) fmt::format_to(it, "% method: {}\n", one_line(info.method));
    fmt::format_to(
        it,
        "% patches: {}, stored entries: {}, threshold: {:.17g} (entries <= threshold dropped)\n",
        F.n, F.nonzeros(), F.threshold);
    fmt::format_to(it, "% repair: {}\n", one_line(info.repair));
    fmt::format_to(it, "{} {} {}\n", F.n, F.n, F.nonzeros());
    constexpr std::size_t kFlush = 1 << 20;
    for (std::size_t i = 0; i < F.n; ++i) {
        for (auto k = F.indptr[i]; k < F.indptr[i + 1]; ++k) {
            const auto kk = static_cast<std::size_t>(k);
            fmt::format_to(it, "{} {} {:.17g}\n", i + 1, F.indices[kk] + 1, F.values[kk]);
        }
        if (buf.size() >= kFlush) {
            out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
            buf.clear();
            process_cancellation().throw_if_requested();
        }
    }
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_sparse_matrix(const std::string& path, const SparseFormFactors& F,
                         const SparseFileInfo& info) {
    const SparseMatrixFormat format = sparse_matrix_format_for(path);
    if (info.patches && info.patches->size() != F.n)
        throw Error("sparse matrix file: the patch table does not match F");
    if (format == SparseMatrixFormat::MatrixMarket) {
        write_file_atomically(path, [&](std::ostream& out) { write_matrix_market(out, F, info); });
        return;
    }
    // HDF5 writes by file name: the same temporary-and-rename protocol by hand.
    process_cancellation().throw_if_requested();
    check_output_directory(path);
    if (std::filesystem::is_directory(path)) throw InputError(path, 0, "is a directory");
    const std::string temporary = temporary_path_for(path);
    try {
        detail::write_sparse_hdf5(temporary, path, F, info);
        process_cancellation().throw_if_requested();
    } catch (...) {
        std::error_code ec;
        std::filesystem::remove(temporary, ec);
        throw;
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        std::error_code ec;
        std::filesystem::remove(temporary, ec);
        throw InputError(path, 0, "cannot rename the temporary file into place");
    }
}

}  // namespace formfactor
