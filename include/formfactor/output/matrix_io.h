#pragma once
/// Form-factor matrix files, chosen by extension (row i = from patch i, 0-based patch order of
/// the scene):
///  - `.csv`  dense N×N, no header, comma-separated, each value printed with `%.17g` so that a
///            double reads back bit for bit;
///  - `.npy`  NumPy NPY format 1.0, `<f8` (little-endian float64), C order, shape (N, N);
///            `numpy.load("F.npy")` reads it;
///  - `.txt`  View3D 3.2's text view-factor file (format 0), which View3D's own tools and
///            EnergyPlus-era scripts read: a 31-byte header line `View3D 3.2 0 encl didemit N`
///            (space-padded to 30 characters), the N areas (`%g`), N rows of F (`%.6f`), the N
///            emissivities (`%.3f`); values separated by one space. Layout of SaveF0() and
///            SaveVF() in View3D 3.2's savevf.c (G. Walton, NIST; github.com/NREL/View3D-3.2).
///            Note the limited precision: this format is for interchange, not for archiving.
///  - `.dat`  Elmer's view-factor file (`ViewFactors.dat`, ASCII), the layout Elmer's radiation
///            solver reads (RadiationFactors.F90, "Viewfactor Binary Output" off): for each
///            row i = 1..N in order, a line with the number n_i of its stored entries, then n_i
///            lines `i j F_ij`, 1-based, the receiving patch j in the same order; entries
///            F_ij = 0 are left out; values `%.17g`. Elmer's rows are its radiation boundary
///            elements, in its own order: the patches must be those elements.

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/matrix/form_factors.h"

namespace formfactor {

/// The matrix file formats.
enum class MatrixFormat { Csv, Npy, View3dText, ElmerDat };

/// The format for `path`'s extension (case-insensitive). Throws
/// OptionError(option, "unknown output extension '.xyz' (use .csv, .npy, .txt or .dat)"); call it
/// before any computation so that a bad output path fails at once (the CLI passes its flag).
MatrixFormat matrix_format_for(const std::string& path, const std::string& option = "output");

/// What a matrix file may carry beyond F (only `.txt` uses it).
struct MatrixFileInfo {
    std::vector<double> areas;         ///< patch areas (required by `.txt`)
    std::vector<double> emissivities;  ///< per patch; empty = 0.9 each (View3D's default)
    bool enclosure = false;            ///< View3D header `encl`
    bool did_emit = false;             ///< View3D header `didemit`: F already includes ε
};

/// Writes F to `path` atomically in the format of its extension (matrix_format_for). Throws
/// OptionError for an unknown extension, InputError(path, ...) on I/O failure, Error when `.txt`
/// lacks areas or the vectors do not match F's size.
void write_matrix(const std::string& path, const DenseMatrix& F, const MatrixFileInfo& info = {});
/// Same, taking areas from `ff`.
void write_matrix(const std::string& path, const FormFactors& ff,
                  const std::vector<double>& emissivities = {}, bool enclosure = false);

/// Stream writers behind write_matrix (the stream should be binary for NPY). The text formats
/// are formatted in blocks of rows on all cores and written in order, a block per write; the
/// numbers are exactly C's printf conversions named above.
void write_csv_matrix(std::ostream& out, const DenseMatrix& F);
void write_npy_matrix(std::ostream& out, const DenseMatrix& F);
void write_view3d_text(std::ostream& out, const DenseMatrix& F, const MatrixFileInfo& info);
void write_elmer_view_factors(std::ostream& out, const DenseMatrix& F);
/// The stream writer of `format`: write_csv_matrix, write_npy_matrix, write_view3d_text or
/// write_elmer_view_factors.
void write_matrix(std::ostream& out, MatrixFormat format, const DenseMatrix& F,
                  const MatrixFileInfo& info = {});

/// The NPY 1.0 header (magic, version, length, dict, padding, newline) for an N×M `<f8`
/// C-order array; its size is a multiple of 64 bytes.
std::string npy_header(std::size_t rows, std::size_t cols);

/// Reads a matrix from `path` by extension (`.csv`, `.npy`, `.txt`, `.dat`). Throws
/// OptionError(option,
/// ...) for another extension and InputError("FILE:LINE: message") for bad content (NPY errors
/// carry no line). Only finite values are accepted.
DenseMatrix read_matrix(const std::string& path, const std::string& option = "matrix");
/// A dense CSV matrix: every line the same number of comma-separated numbers (blank lines and
/// lines starting with '#' are skipped). `name` is used in error messages.
DenseMatrix read_csv_matrix(std::istream& in, const std::string& name);
/// An NPY file (format 1.0, 2.0 or 3.0) holding a 2-D `<f8` or `<f4` array, C or Fortran order.
DenseMatrix read_npy_matrix(std::istream& in, const std::string& name);

/// An Elmer view-factor file (`.dat`, layout above): N is the number of row blocks; every
/// block's row number must be its position, every column in 1..N and not repeated in a row, every
/// value finite. Throws InputError("FILE:LINE: message").
DenseMatrix read_elmer_view_factors(std::istream& in, const std::string& name);

/// A View3D 3.2 text view-factor file.
struct View3dFile {
    std::string program, version;
    int format = 0, encl = 0, didemit = 0;
    std::vector<double> areas, emissivities;
    DenseMatrix F;
};
/// Reads a View3D 3.2 text file (format 0) as written by View3D or write_view3d_text.
View3dFile read_view3d_text(std::istream& in, const std::string& name);

}  // namespace formfactor
