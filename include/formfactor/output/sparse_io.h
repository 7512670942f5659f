#pragma once
/// Sparse form-factor files (formfactor/matrix/sparse.h), chosen by extension, written row by
/// row from the CSR arrays (never through a dense copy), to a temporary name renamed into place
/// (formfactor/output/atomic_file.h):
///  - `.mtx`  Matrix Market coordinate, `real general`: a header comment (program, scene,
///            method, threshold, the direction: row i = from patch i, F_ij from i to j), the
///            size line `N N nonzeros`, then one `i j F_ij` line per entry, 1-based as Matrix
///            Market requires, rows ascending, values `%.17g` (read back bit for bit).
///            scipy.io.mmread("F.mtx"), MATLAB's mmread, Julia's MatrixMarket.mmread read it.
///  - `.h5`   HDF5 (docs/sparse.md has the layout): datasets `indptr` (int64, N + 1),
///            `indices` (int32, 0-based), `data` (float64) — SciPy's CSR arrays —, `areas`,
///            `sky_factor` (1 − Σ_j F_ij per patch), `dropped` (mass the threshold dropped, per
///            row), `computed_row_sum`, optional `standard_error` (per entry), the patch table
///            in group `patches` (`surface` int32, `centroid` and `normal` N × 3 float64), and
///            attributes `N`, `nonzeros`, `threshold`, `dropped_mass`, `scene`, `method`,
///            `repair`, `direction`, `format`, `format_version`. With h5py and SciPy:
///
///                import h5py, scipy.sparse
///                f = h5py.File("F.h5", "r")
///                F = scipy.sparse.csr_matrix((f["data"], f["indices"], f["indptr"]),
///                shape=(f.attrs["N"],) * 2)

#include <iosfwd>
#include <string>
#include <vector>

#include "formfactor/matrix/sparse.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// The sparse matrix file formats.
enum class SparseMatrixFormat { MatrixMarket, Hdf5 };

/// True when `path` ends in `.mtx` or `.h5` (case-insensitive).
bool is_sparse_matrix_path(const std::string& path);

/// The format for `path`'s extension; throws OptionError(option, "unknown ...") otherwise.
SparseMatrixFormat sparse_matrix_format_for(const std::string& path,
                                            const std::string& option = "output");

/// What a sparse file says beyond F.
struct SparseFileInfo {
    std::string scene;            ///< the scene's name or path
    std::string method;           ///< the method's name
    std::string repair = "none";  ///< the repair applied (none, reciprocity, closure)
    /// The patches, for the patch table of `.h5` (surface, centroid, normal); null: no table.
    const std::vector<Patch>* patches = nullptr;
};

/// Writes F to `path` atomically in the format of its extension. Throws OptionError for an
/// unknown extension, Error when the patch table does not match F, InputError(path, ...) on I/O
/// failure (nothing is left behind), Cancelled when the process is asked to stop.
void write_sparse_matrix(const std::string& path, const SparseFormFactors& F,
                         const SparseFileInfo& info = {});

/// Reads a sparse F back from a `.mtx` file (Matrix Market `coordinate real general` or
/// `integer general`, 1-based, entries in any order, none repeated, N × N) or a `.h5` file of
/// the layout above (its `indptr`, `indices`, `data`, `areas` and, when present,
/// `computed_row_sum`, `dropped`, `standard_error`). A `.mtx` file holds no areas: they are left
/// empty for the caller to give (the scene's), the computed row sums are the stored ones and
/// nothing counts as dropped. Throws OptionError(option, ...) for another extension and
/// InputError(path, line, what is wrong) for a file that is not such a matrix: a bad header or
/// size line, an index out of range, a repeated entry, a non-finite value, a missing or extra
/// entry, inconsistent CSR arrays, sizes that would not fit in memory.
SparseFormFactors read_sparse_matrix(const std::string& path, const std::string& option = "matrix");
/// The Matrix Market reader behind read_sparse_matrix (`name` names the input in messages).
SparseFormFactors read_matrix_market(std::istream& in, const std::string& name);
/// The Matrix Market writer behind write_sparse_matrix (rows formatted in blocks).
void write_matrix_market(std::ostream& out, const SparseFormFactors& F,
                         const SparseFileInfo& info = {});

}  // namespace formfactor
