#include "formfactor/output/matrix_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <istream>
#include <ostream>
#include <sstream>

#include "core/text.h"
#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "output/extension.h"

namespace formfactor {

using detail::lower_extension;

using detail::parse_double;
using detail::trim;

namespace {

void write_le_double(std::ostream& out, const double* values, std::size_t count) {
    if constexpr (std::endian::native == std::endian::little) {
        out.write(reinterpret_cast<const char*>(values),
                  static_cast<std::streamsize>(count * sizeof(double)));
    } else {
        for (std::size_t k = 0; k < count; ++k) {
            auto bits = std::bit_cast<std::uint64_t>(values[k]);
            char bytes[8];
            for (int b = 0; b < 8; ++b) bytes[b] = static_cast<char>((bits >> (8 * b)) & 0xff);
            out.write(bytes, 8);
        }
    }
}

void check_info(const DenseMatrix& F, const MatrixFileInfo& info, bool need_areas) {
    const auto n = static_cast<std::size_t>(F.rows());
    if (need_areas && info.areas.size() != n) {
        throw Error(fmt::format("the View3D .txt output needs the {} patch areas (got {})", n,
                                info.areas.size()));
    }
    if (!info.emissivities.empty() && info.emissivities.size() != n) {
        throw Error(
            fmt::format("{} emissivities given for {} patches", info.emissivities.size(), n));
    }
}

}  // namespace

MatrixFormat matrix_format_for(const std::string& path, const std::string& option) {
    const std::string ext = lower_extension(path);
    if (ext == ".csv") return MatrixFormat::Csv;
    if (ext == ".npy") return MatrixFormat::Npy;
    if (ext == ".txt") return MatrixFormat::View3dText;
    if (ext == ".dat") return MatrixFormat::ElmerDat;
    if (ext.empty()) {
        throw OptionError(option, "'" + path + "' has no extension (use .csv, .npy, .txt or .dat)");
    }
    throw OptionError(option,
                      "unknown output extension '" + ext + "' (use .csv, .npy, .txt or .dat)");
}

// ---- writers ------------------------------------------------------------------------------

namespace {

// Text matrices are formatted a block of rows at a time, a wave of blocks in parallel
// (parallel_for, each block into its own buffer), and written in order, one write per block,
// by a second thread while the next wave is formatted: the file system's time hides behind the
// formatting. The bytes are those of a serial loop.
constexpr std::size_t kBlockBytes = std::size_t(1) << 21;

template <class FormatRow>
void write_rows(std::ostream& out, std::size_t rows, std::size_t row_bytes, FormatRow format_row) {
    if (rows == 0) return;
    const std::size_t per_block =
        std::clamp<std::size_t>(kBlockBytes / std::max<std::size_t>(row_bytes, 1), 1, rows);
    const std::size_t blocks = (rows + per_block - 1) / per_block;
    const int threads = blocks > 1 ? effective_threads(0) : 1;
    const std::size_t wave = std::min(blocks, 2 * static_cast<std::size_t>(threads));
    std::vector<detail::TextBuffer> buffers[2] = {std::vector<detail::TextBuffer>(wave),
                                                  std::vector<detail::TextBuffer>(wave)};
    std::future<void> writing;
    for (std::size_t b0 = 0, w = 0; b0 < blocks; b0 += wave, w ^= 1) {
        const std::size_t count = std::min(wave, blocks - b0);
        std::vector<detail::TextBuffer>& bufs = buffers[w];
        parallel_for(count, threads, [&](std::size_t k) {
            detail::TextBuffer& buf = bufs[k];
            buf.clear();
            const std::size_t first = (b0 + k) * per_block;
            for (std::size_t i = first; i < std::min(rows, first + per_block); ++i)
                format_row(i, buf);
        });
        if (writing.valid()) writing.get();
        if (!out) return;  // the caller reports the stream's failure
        writing = std::async(std::launch::async, [&out, &bufs, count] {
            for (std::size_t k = 0; k < count && out; ++k)
                out.write(bufs[k].data(), static_cast<std::streamsize>(bufs[k].size()));
        });
    }
    writing.get();
}

// One line of values separated by `sep`, each printed by print(p, value).
template <class Print>
void format_line(detail::TextBuffer& buf, const double* values, std::size_t count, char sep,
                 Print print) {
    for (std::size_t j = 0; j < count; ++j) {
        char* p = buf.room(detail::kMaxNumberChars + 2);
        if (j > 0) *p++ = sep;
        buf.commit(print(p, values[j]));
    }
    buf.put('\n');
}

}  // namespace

void write_csv_matrix(std::ostream& out, const DenseMatrix& F) {
    // DenseMatrix is row-major: row i is contiguous.
    const auto cols = static_cast<std::size_t>(F.cols());
    write_rows(out, static_cast<std::size_t>(F.rows()), 24 * cols,
               [&](std::size_t i, detail::TextBuffer& buf) {
                   format_line(buf, F.data() + i * cols, cols, ',', detail::print_g17);
               });
}

std::string npy_header(std::size_t rows, std::size_t cols) {
    // NPY 1.0: magic "\x93NUMPY", version 1.0, uint16 little-endian header length, then an ASCII
    // dict padded with spaces and ended by '\n' so that the data starts at a multiple of 64.
    std::string dict =
        fmt::format("{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, {}), }}", rows, cols);
    const std::size_t preamble = 10;  // magic (6) + version (2) + length (2)
    std::size_t total = preamble + dict.size() + 1;
    total = (total + 63) / 64 * 64;
    dict.append(total - preamble - dict.size() - 1, ' ');
    dict.push_back('\n');
    const std::size_t len = dict.size();
    if (len > 0xffff) throw Error("NPY header too long");
    std::string header("\x93NUMPY\x01\x00", 8);
    header.push_back(static_cast<char>(len & 0xff));
    header.push_back(static_cast<char>((len >> 8) & 0xff));
    header += dict;
    return header;
}

void write_npy_matrix(std::ostream& out, const DenseMatrix& F) {
    const std::string header =
        npy_header(static_cast<std::size_t>(F.rows()), static_cast<std::size_t>(F.cols()));
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    // DenseMatrix is row-major, i.e. C order, and contiguous.
    write_le_double(out, F.data(), static_cast<std::size_t>(F.size()));
}

void write_view3d_text(std::ostream& out, const DenseMatrix& F, const MatrixFileInfo& info) {
    check_info(F, info, true);
    const auto n = static_cast<std::size_t>(F.rows());
    const auto cols = static_cast<std::size_t>(F.cols());
    // SaveVF(): "program version format encl didemit nSrf", padded with spaces to 30 characters,
    // then '\n' (format 0 = text).
    std::string header =
        fmt::format("View3D 3.2 0 {} {} {}", info.enclosure ? 1 : 0, info.did_emit ? 1 : 0, n);
    if (header.size() < 30) header.append(30 - header.size(), ' ');
    header.push_back('\n');
    // SaveF0(): areas "%g", rows "%.6f", emissivities "%.3f", one space between values.
    detail::TextBuffer buf;
    buf.append(header);
    format_line(buf, info.areas.data(), n, ' ', detail::print_g);
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    write_rows(out, n, 9 * cols, [&](std::size_t i, detail::TextBuffer& row) {
        format_line(row, F.data() + i * cols, cols, ' ',
                    [](char* p, double x) { return detail::print_fixed(p, x, 6); });
    });
    const std::vector<double> default_emissivities(info.emissivities.empty() ? n : 0, 0.9);
    const std::vector<double>& e =
        info.emissivities.empty() ? default_emissivities : info.emissivities;
    buf.clear();
    format_line(buf, e.data(), n, ' ',
                [](char* p, double x) { return detail::print_fixed(p, x, 3); });
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_elmer_view_factors(std::ostream& out, const DenseMatrix& F) {
    // Per row: the count of its nonzero entries, then "i j F_ij" lines (1-based), as Elmer's
    // RadiationFactors.F90 reads them with list-directed READs.
    const auto cols = static_cast<std::size_t>(F.cols());
    write_rows(out, static_cast<std::size_t>(F.rows()), 32 * cols,
               [&](std::size_t i, detail::TextBuffer& buf) {
                   const double* row = F.data() + i * cols;
                   std::size_t nonzero = 0;
                   for (std::size_t j = 0; j < cols; ++j) nonzero += row[j] != 0.0;
                   char* p = buf.room(24);
                   p = detail::print_integer(p, static_cast<long long>(nonzero));
                   *p++ = '\n';
                   buf.commit(p);
                   for (std::size_t j = 0; j < cols; ++j) {
                       if (row[j] == 0.0) continue;
                       p = buf.room(detail::kMaxNumberChars + 48);
                       p = detail::print_integer(p, static_cast<long long>(i + 1));
                       *p++ = ' ';
                       p = detail::print_integer(p, static_cast<long long>(j + 1));
                       *p++ = ' ';
                       p = detail::print_g17(p, row[j]);
                       *p++ = '\n';
                       buf.commit(p);
                   }
               });
}

void write_matrix(std::ostream& out, MatrixFormat format, const DenseMatrix& F,
                  const MatrixFileInfo& info) {
    switch (format) {
        case MatrixFormat::Csv:
            write_csv_matrix(out, F);
            break;
        case MatrixFormat::Npy:
            write_npy_matrix(out, F);
            break;
        case MatrixFormat::View3dText:
            write_view3d_text(out, F, info);
            break;
        case MatrixFormat::ElmerDat:
            write_elmer_view_factors(out, F);
            break;
    }
}

void write_matrix(const std::string& path, const DenseMatrix& F, const MatrixFileInfo& info) {
    const MatrixFormat format = matrix_format_for(path);
    if (F.rows() != F.cols()) throw Error(path + ": the form-factor matrix is not square");
    check_info(F, info, format == MatrixFormat::View3dText);
    write_file_atomically(path, [&](std::ostream& out) { write_matrix(out, format, F, info); });
}

void write_matrix(const std::string& path, const FormFactors& ff,
                  const std::vector<double>& emissivities, bool enclosure) {
    MatrixFileInfo info;
    info.areas = ff.areas;
    info.emissivities = emissivities;
    info.enclosure = enclosure;
    write_matrix(path, ff.F, info);
}

// ---- readers ------------------------------------------------------------------------------

DenseMatrix read_csv_matrix(std::istream& in, const std::string& name) {
    std::vector<double> values;
    std::size_t cols = 0, rows = 0;
    int first_line = 0;
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string t = trim(line);
        if (t.empty() || t[0] == '#') continue;
        std::size_t count = 0;
        std::size_t start = 0;
        while (true) {
            const std::size_t comma = t.find(',', start);
            const std::string token = trim(std::string_view(t).substr(
                start, comma == std::string::npos ? std::string::npos : comma - start));
            ++count;
            double v = 0.0;
            if (!parse_double(token, v)) {
                throw InputError(name, line_no,
                                 token.empty() ? fmt::format("empty value in column {}", count)
                                               : fmt::format("malformed number '{}' in column {}",
                                                             token, count));
            }
            if (!std::isfinite(v)) {
                throw InputError(name, line_no,
                                 fmt::format("non-finite value '{}' in column {}", token, count));
            }
            values.push_back(v);
            if (comma == std::string::npos) break;
            start = comma + 1;
        }
        if (rows == 0) {
            cols = count;
            first_line = line_no;
        } else if (count != cols) {
            throw InputError(name, line_no,
                             fmt::format("{} values, but line {} has {}", count, first_line, cols));
        }
        ++rows;
    }
    if (in.bad()) throw InputError(name, 0, "read error");
    if (rows == 0) throw InputError(name, 0, "no matrix rows");
    DenseMatrix F(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    std::copy(values.begin(), values.end(), F.data());
    return F;
}

namespace {

/// Value of `key` in an NPY header dict: the text after "'key':" up to the next ',' at depth 0
/// (or the closing brace).
std::string npy_dict_value(const std::string& dict, const std::string& key,
                           const std::string& name) {
    const std::string quoted1 = "'" + key + "'";
    const std::string quoted2 = "\"" + key + "\"";
    std::size_t at = dict.find(quoted1);
    std::size_t klen = quoted1.size();
    if (at == std::string::npos) {
        at = dict.find(quoted2);
        klen = quoted2.size();
    }
    if (at == std::string::npos) throw InputError(name, 0, "NPY header has no '" + key + "'");
    std::size_t p = dict.find(':', at + klen);
    if (p == std::string::npos) throw InputError(name, 0, "malformed NPY header");
    ++p;
    int depth = 0;
    std::size_t e = p;
    for (; e < dict.size(); ++e) {
        const char c = dict[e];
        if (c == '(') ++depth;
        if (c == ')') --depth;
        if (depth == 0 && (c == ',' || c == '}')) break;
    }
    return trim(std::string_view(dict).substr(p, e - p));
}

}  // namespace

DenseMatrix read_npy_matrix(std::istream& in, const std::string& name) {
    char pre[8];
    if (!in.read(pre, 8) || std::memcmp(pre, "\x93NUMPY", 6) != 0) {
        throw InputError(name, 0, "not an NPY file (bad magic string)");
    }
    const int major = static_cast<unsigned char>(pre[6]);
    std::size_t header_len = 0;
    if (major == 1) {
        unsigned char b[2];
        if (!in.read(reinterpret_cast<char*>(b), 2))
            throw InputError(name, 0, "truncated NPY header");
        header_len = b[0] | (static_cast<std::size_t>(b[1]) << 8);
    } else if (major == 2 || major == 3) {
        unsigned char b[4];
        if (!in.read(reinterpret_cast<char*>(b), 4))
            throw InputError(name, 0, "truncated NPY header");
        header_len = b[0] | (static_cast<std::size_t>(b[1]) << 8) |
                     (static_cast<std::size_t>(b[2]) << 16) |
                     (static_cast<std::size_t>(b[3]) << 24);
    } else {
        throw InputError(name, 0, fmt::format("unsupported NPY version {}", major));
    }
    // NumPy's own reader refuses headers over 10,000 bytes; a 2-D float array needs < 200.
    if (header_len > (1u << 16)) {
        throw InputError(name, 0,
                         fmt::format("NPY header too long ({} bytes, at most 65536)", header_len));
    }
    std::string dict(header_len, '\0');
    if (!in.read(dict.data(), static_cast<std::streamsize>(header_len))) {
        throw InputError(name, 0, "truncated NPY header");
    }
    std::string descr = npy_dict_value(dict, "descr", name);
    if (descr.size() >= 2 && (descr.front() == '\'' || descr.front() == '"')) {
        descr = descr.substr(1, descr.size() - 2);
    }
    std::size_t item = 0;
    if (descr == "<f8") {
        item = 8;
    } else if (descr == "<f4") {
        item = 4;
    } else {
        throw InputError(name, 0, "unsupported NPY dtype '" + descr + "' (expected '<f8')");
    }
    const std::string order = npy_dict_value(dict, "fortran_order", name);
    bool fortran = false;
    if (order == "True") {
        fortran = true;
    } else if (order != "False") {
        throw InputError(name, 0, "malformed NPY fortran_order '" + order + "'");
    }
    const std::string shape_text = npy_dict_value(dict, "shape", name);
    std::vector<std::size_t> shape;
    {
        if (shape_text.size() < 2 || shape_text.front() != '(' || shape_text.back() != ')') {
            throw InputError(name, 0, "malformed NPY shape '" + shape_text + "'");
        }
        std::stringstream ss(shape_text.substr(1, shape_text.size() - 2));
        std::string part;
        while (std::getline(ss, part, ',')) {
            const std::string t = trim(part);
            if (t.empty()) continue;
            std::size_t v = 0;
            if (!detail::parse_size(t, v)) {
                throw InputError(name, 0, "malformed NPY shape '" + shape_text + "'");
            }
            shape.push_back(v);
        }
    }
    if (shape.size() != 2) {
        throw InputError(name, 0, "expected a 2-D array, found shape " + shape_text);
    }
    const std::size_t rows = shape[0], cols = shape[1];
    // Like the CSV reader, no empty matrix: a shape (0, 2^62) would otherwise make an "empty"
    // matrix whose every column a later loop visits. Each side must fit Eigen's (signed) index.
    if (rows == 0 || cols == 0) {
        throw InputError(name, 0, "empty NPY array (shape " + shape_text + ")");
    }
    constexpr std::size_t kMaxSide = std::size_t(1) << 31;
    if (rows > kMaxSide || cols > kMaxSide || cols > (std::size_t(1) << 40) / rows) {
        throw InputError(name, 0, "NPY array too large (shape " + shape_text + ")");
    }
    const std::size_t count = rows * cols;
    // The shape is only the header's claim: read the data in pieces, so that a header claiming
    // 10^12 values costs no more memory than the file really holds before it is found short.
    std::vector<char> bytes;
    constexpr std::size_t kPiece = std::size_t(1) << 20;
    while (bytes.size() < count * item) {
        const std::size_t old = bytes.size();
        const std::size_t step = std::min(kPiece, count * item - old);
        bytes.resize(old + step);
        if (!in.read(bytes.data() + old, static_cast<std::streamsize>(step))) {
            throw InputError(
                name, 0,
                fmt::format("truncated NPY data: the header says {}×{} values of {} bytes, the "
                            "file holds {} bytes of data",
                            rows, cols, item, old + static_cast<std::size_t>(in.gcount())));
        }
    }
    if (in.peek() != std::char_traits<char>::eof()) {
        throw InputError(name, 0, "unexpected data after the NPY array");
    }
    DenseMatrix F(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
    for (std::size_t k = 0; k < count; ++k) {
        double v = 0.0;
        if (item == 8) {
            std::uint64_t bits = 0;
            for (int b = 7; b >= 0; --b)
                bits = (bits << 8) |
                       static_cast<unsigned char>(bytes[k * 8 + static_cast<std::size_t>(b)]);
            v = std::bit_cast<double>(bits);
        } else {
            std::uint32_t bits = 0;
            for (int b = 3; b >= 0; --b)
                bits = (bits << 8) |
                       static_cast<unsigned char>(bytes[k * 4 + static_cast<std::size_t>(b)]);
            v = static_cast<double>(std::bit_cast<float>(bits));
        }
        const std::size_t i = fortran ? k % rows : k / cols;
        const std::size_t j = fortran ? k / rows : k % cols;
        if (!std::isfinite(v)) {
            throw InputError(name, 0, fmt::format("non-finite value at row {}, column {}", i, j));
        }
        F(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = v;
    }
    return F;
}

View3dFile read_view3d_text(std::istream& in, const std::string& name) {
    View3dFile f;
    std::string line;
    if (!std::getline(in, line)) throw InputError(name, 1, "empty file (expected a View3D header)");
    long long header_n = -1;
    {
        std::istringstream hs(line);
        if (!(hs >> f.program >> f.version >> f.format >> f.encl >> f.didemit >> header_n) ||
            header_n < 0) {
            throw InputError(name, 1,
                             "malformed View3D header (expected 'View3D 3.2 format encl didemit "
                             "nsrf')");
        }
        if (f.format != 0) {
            throw InputError(name, 1,
                             fmt::format("View3D format {} is not the text format 0", f.format));
        }
        // n + n² + n must not overflow; the values themselves are read before anything of the
        // header's size is allocated, so a header claiming 10^9 surfaces costs nothing.
        if (header_n > (1LL << 30)) {
            throw InputError(name, 1,
                             fmt::format("the header claims {} surfaces (too many)", header_n));
        }
    }
    const auto n = static_cast<std::size_t>(header_n);
    const std::size_t total = n + n * n + n;
    std::vector<double> values;
    int line_no = 1;
    while (values.size() < total && std::getline(in, line)) {
        ++line_no;
        std::istringstream ls(line);
        std::string token;
        while (ls >> token) {
            double v = 0.0;
            if (!parse_double(token, v)) {
                throw InputError(name, line_no, "malformed number '" + token + "'");
            }
            if (!std::isfinite(v)) {
                throw InputError(name, line_no, "non-finite value '" + token + "'");
            }
            if (values.size() >= total) {
                throw InputError(name, line_no, "more values than the header says");
            }
            values.push_back(v);
        }
    }
    if (values.size() < total) {
        throw InputError(name, line_no,
                         fmt::format("file ends after {} of {} values", values.size(), total));
    }
    const auto first = values.begin();
    const auto nn = static_cast<std::ptrdiff_t>(n);
    f.areas.assign(first, first + nn);
    f.F.resize(nn, nn);
    std::copy(first + nn, first + nn + nn * nn, f.F.data());
    f.emissivities.assign(first + nn + nn * nn, first + nn + nn * nn + nn);
    return f;
}

DenseMatrix read_matrix(const std::string& path, const std::string& option) {
    const std::string ext = lower_extension(path);
    if (ext != ".csv" && ext != ".npy" && ext != ".txt" && ext != ".dat") {
        throw OptionError(option,
                          "unknown matrix extension '" + ext + "' (use .csv, .npy, .txt or .dat)");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
    DenseMatrix F;
    if (ext == ".csv") {
        F = read_csv_matrix(in, path);
    } else if (ext == ".npy") {
        F = read_npy_matrix(in, path);
    } else if (ext == ".dat") {
        F = read_elmer_view_factors(in, path);
    } else {
        F = read_view3d_text(in, path).F;
    }
    if (F.rows() != F.cols()) {
        throw InputError(path, 0,
                         fmt::format("the matrix is {}×{}, not square", F.rows(), F.cols()));
    }
    return F;
}

}  // namespace formfactor
