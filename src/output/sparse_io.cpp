// Sparse matrix files: Matrix Market coordinate text, and HDF5 (sparse_hdf5.cpp), both written
// to a temporary name and renamed into place.

#include "formfactor/output/sparse_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <istream>
#include <ostream>
#include <system_error>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/matrix/memory.h"
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

namespace {

// The words of a line (spaces and tabs), lower-cased when asked.
std::vector<std::string_view> words_of(std::string_view line) {
    std::vector<std::string_view> w;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
        const std::size_t b = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
        if (i > b) w.push_back(line.substr(b, i - b));
    }
    return w;
}

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

template <class T>
bool parse_whole(std::string_view w, T& out) {
    const char* end = w.data() + w.size();
    const auto [p, ec] = std::from_chars(w.data(), end, out);
    return ec == std::errc() && p == end;
}

struct Triplet {
    std::int32_t row, col;
    double value;
};

}  // namespace

SparseFormFactors read_matrix_market(std::istream& in, const std::string& name) {
    std::string line;
    int number = 0;
    auto fail = [&](const std::string& what) { throw InputError(name, number, what); };
    if (!std::getline(in, line)) {
        number = 1;
        fail("empty file (expected '%%MatrixMarket matrix coordinate real general')");
    }
    ++number;
    {
        const auto w = words_of(line);
        if (w.size() != 5 || w[0] != "%%MatrixMarket" || lower(w[1]) != "matrix")
            fail(
                "not a Matrix Market file (expected '%%MatrixMarket matrix coordinate real "
                "general')");
        if (lower(w[2]) != "coordinate")
            fail("'" + std::string(w[2]) + "' format: a sparse F is read from 'coordinate'");
        const std::string field = lower(w[3]), symmetry = lower(w[4]);
        if (field != "real" && field != "integer" && field != "double")
            fail("field '" + std::string(w[3]) + "': form factors are real");
        if (symmetry != "general")
            fail("symmetry '" + std::string(w[4]) +
                 "': form factors are not symmetric (A_i F_ij is); expected 'general'");
    }
    // Comments, then the size line.
    std::size_t rows = 0, cols = 0, entries = 0;
    while (true) {
        if (!std::getline(in, line)) fail("no size line 'N N nonzeros'");
        ++number;
        if (!line.empty() && line[0] == '%') continue;
        const auto w = words_of(line);
        if (w.empty()) continue;
        if (w.size() != 3 || !parse_whole(w[0], rows) || !parse_whole(w[1], cols) ||
            !parse_whole(w[2], entries))
            fail("expected the size line 'N N nonzeros' (three whole numbers)");
        break;
    }
    if (rows != cols) fail(fmt::format("F is square: {} rows, {} columns", rows, cols));
    if (rows > std::size_t(INT32_MAX)) fail(fmt::format("{} patches: more than 2^31 - 1", rows));
    if (rows == 0 ? entries > 0
                  : entries / rows > rows || (entries / rows == rows && entries % rows != 0))
        fail(fmt::format("{} entries in a {} x {} matrix", entries, rows, rows));
    const double bytes = sparse_matrix_bytes(double(rows), double(entries), false) +
                         double(entries) * double(sizeof(Triplet));
    if (const double available = available_memory(); available > 0.0 && bytes > available)
        fail(fmt::format("{} entries need {:.3g} GB, more than the {:.3g} GB available", entries,
                         bytes / 1e9, available / 1e9));
    std::vector<Triplet> t;
    t.reserve(std::min<std::size_t>(entries, std::size_t(1) << 20));
    while (t.size() < entries) {
        if (!std::getline(in, line))
            fail(fmt::format("{} entries, the size line says {}", t.size(), entries));
        ++number;
        const auto w = words_of(line);
        if (w.empty() || (!line.empty() && line[0] == '%')) continue;
        std::size_t i = 0, j = 0;
        double v = 0.0;
        if (w.size() != 3 || !parse_whole(w[0], i) || !parse_whole(w[1], j) ||
            !parse_whole(w[2], v))
            fail("expected an entry 'i j value'");
        if (i < 1 || i > rows || j < 1 || j > rows)
            fail(fmt::format("entry ({}, {}) outside the {} x {} matrix (indices are 1-based)", i,
                             j, rows, rows));
        if (!std::isfinite(v)) fail("value is not a finite number");
        t.push_back({static_cast<std::int32_t>(i - 1), static_cast<std::int32_t>(j - 1), v});
        if ((t.size() & 0xFFFFF) == 0) process_cancellation().throw_if_requested();
    }
    while (std::getline(in, line)) {
        ++number;
        if (!words_of(line).empty() && line[0] != '%')
            fail(fmt::format("more entries than the {} of the size line", entries));
    }
    std::stable_sort(t.begin(), t.end(), [](const Triplet& a, const Triplet& b) {
        return a.row != b.row ? a.row < b.row : a.col < b.col;
    });
    SparseFormFactors F;
    F.n = rows;
    F.indptr.assign(rows + 1, 0);
    F.indices.reserve(t.size());
    F.values.reserve(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
        if (k > 0 && t[k].row == t[k - 1].row && t[k].col == t[k - 1].col) {
            number = 0;
            fail(fmt::format("entry ({}, {}) is given twice", t[k].row + 1, t[k].col + 1));
        }
        F.indices.push_back(t[k].col);
        F.values.push_back(t[k].value);
        ++F.indptr[static_cast<std::size_t>(t[k].row) + 1];
    }
    for (std::size_t i = 0; i < rows; ++i) F.indptr[i + 1] += F.indptr[i];
    F.computed_row_sums.resize(rows);
    for (std::size_t i = 0; i < rows; ++i) F.computed_row_sums[i] = F.row_sum(i);
    F.dropped.assign(rows, 0.0);
    return F;
}

SparseFormFactors read_sparse_matrix(const std::string& path, const std::string& option) {
    const SparseMatrixFormat format = sparse_matrix_format_for(path, option);
    if (std::filesystem::is_directory(path)) throw InputError(path, 0, "is a directory");
    SparseFormFactors F;
    if (format == SparseMatrixFormat::MatrixMarket) {
        std::ifstream in(path, std::ios::binary);
        if (!in) throw InputError(path, 0, "cannot open file");
        F = read_matrix_market(in, path);
    } else {
        F = detail::read_sparse_hdf5(path);
    }
    return F;
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
