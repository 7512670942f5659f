#pragma once
// The HDF5 writer of sparse form factors (the only file that includes hdf5.h is
// sparse_hdf5.cpp).

#include <string>

#include "formfactor/output/sparse_io.h"

namespace formfactor::detail {

/// Writes F to the HDF5 file `file` (created or truncated; no rename here). Throws
/// InputError(target, 0, ...) naming `target` on failure.
void write_sparse_hdf5(const std::string& file, const std::string& target,
                       const SparseFormFactors& F, const SparseFileInfo& info);

/// Reads the CSR arrays, areas and per-row arrays of an HDF5 file of that layout. Throws
/// InputError(path, 0, ...) naming what is missing or inconsistent.
SparseFormFactors read_sparse_hdf5(const std::string& path);

}  // namespace formfactor::detail
