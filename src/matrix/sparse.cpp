// CSR form factors: the row-block builder that thresholds rows as they come, and diagnostics.

#include "formfactor/matrix/sparse.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/matrix/memory.h"

namespace formfactor {

double SparseFormFactors::row_sum(std::size_t i) const {
    double s = 0.0;
    for (auto k = indptr[i]; k < indptr[i + 1]; ++k) s += values[static_cast<std::size_t>(k)];
    return s;
}

double SparseFormFactors::at(std::size_t i, std::size_t j) const {
    const auto first = indices.begin() + indptr[i], last = indices.begin() + indptr[i + 1];
    const auto it = std::lower_bound(first, last, static_cast<std::int32_t>(j));
    if (it == last || *it != static_cast<std::int32_t>(j)) return 0.0;
    return values[static_cast<std::size_t>(it - indices.begin())];
}

double sparse_matrix_bytes(double n, double nonzeros, bool standard_errors) {
    const double per_entry = sizeof(std::int32_t) + sizeof(double) * (standard_errors ? 2 : 1);
    const double per_row = sizeof(std::int64_t) + 3 * sizeof(double);
    return nonzeros * per_entry + (n + 1) * per_row;
}

double SparseFormFactors::memory_bytes() const {
    return sparse_matrix_bytes(double(n), double(nonzeros()), standard_error.has_value());
}

void SparseFormFactors::check() const {
    auto fail = [](const std::string& what) { throw Error("sparse form factors: " + what); };
    if (indptr.size() != n + 1 || indptr.front() != 0)
        fail("indptr must have N + 1 offsets from 0");
    if (static_cast<std::size_t>(indptr.back()) != values.size() || indices.size() != values.size())
        fail("indptr, indices and values disagree on the number of entries");
    if (standard_error && standard_error->size() != values.size())
        fail("standard errors do not match the entries");
    if (areas.size() != n || computed_row_sums.size() != n || dropped.size() != n)
        fail("areas, computed row sums and dropped mass need one value per patch");
    for (std::size_t i = 0; i < n; ++i) {
        if (indptr[i + 1] < indptr[i]) fail("indptr decreases at row " + std::to_string(i));
        for (auto k = indptr[i]; k < indptr[i + 1]; ++k) {
            const auto c = indices[static_cast<std::size_t>(k)];
            if (c < 0 || static_cast<std::size_t>(c) >= n)
                fail("column out of range in row " + std::to_string(i));
            if (k > indptr[i] && indices[static_cast<std::size_t>(k - 1)] >= c)
                fail("columns not ascending in row " + std::to_string(i));
            if (!std::isfinite(values[static_cast<std::size_t>(k)]))
                fail("non-finite entry in row " + std::to_string(i));
        }
    }
}

SparseBuilder::SparseBuilder(std::size_t n, std::vector<double> areas, double threshold,
                             bool standard_errors) {
    if (!(threshold >= 0.0) || !std::isfinite(threshold))
        throw OptionError("threshold", "must be a finite number ≥ 0");
    if (areas.size() != n) throw Error("SparseBuilder: need one area per patch");
    if (n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw OptionError("storage", "sparse storage holds at most 2^31 − 1 patches");
    m_.n = n;
    m_.areas = std::move(areas);
    m_.threshold = threshold;
    if (standard_errors) m_.standard_error.emplace();
    m_.computed_row_sums.reserve(n);
    m_.dropped.reserve(n);
    m_.indptr.reserve(n + 1);
}

void SparseBuilder::reserve(std::size_t nonzeros) {
    m_.values.reserve(nonzeros);
    m_.indices.reserve(nonzeros);
    if (m_.standard_error) m_.standard_error->reserve(nonzeros);
}

namespace {

// Appends m thresholded rows to `out`: count(r, stored, sum, dropped) counts row r's entries
// above the threshold and sums the row and its dropped part; fill(r, k) writes its stored
// entries from position k on. Each row by one task, in its own slice.
template <class Count, class Fill>
void append_rows(SparseFormFactors& out, std::size_t m, int threads, const Count& count_row,
                 const Fill& fill_row) {
    std::vector<std::size_t> count(m), offset(m + 1, 0);
    std::vector<double> sum(m), drop(m);
    parallel_for(m, threads, [&](std::size_t r) { count_row(r, count[r], sum[r], drop[r]); });
    for (std::size_t r = 0; r < m; ++r) offset[r + 1] = offset[r] + count[r];
    const std::size_t base = out.values.size();
    out.values.resize(base + offset[m]);
    out.indices.resize(base + offset[m]);
    if (out.standard_error) out.standard_error->resize(base + offset[m]);
    parallel_for(m, threads, [&](std::size_t r) { fill_row(r, base + offset[r]); });
    for (std::size_t r = 0; r < m; ++r) {
        out.indptr.push_back(static_cast<std::int64_t>(base + offset[r + 1]));
        out.computed_row_sums.push_back(sum[r]);
        out.dropped.push_back(drop[r]);
    }
}

}  // namespace

void SparseBuilder::append(const FormFactors& block, int threads) {
    const std::size_t m = block.size(), n = m_.n, first = rows();
    if (block.first_row != first || static_cast<std::size_t>(block.F.cols()) != n || first + m > n)
        throw Error("SparseBuilder: blocks must come in row order with N columns");
    const bool se = m_.standard_error.has_value();
    if (se && !block.standard_error) throw Error("SparseBuilder: the block has no standard errors");
    const double t = m_.threshold;
    append_rows(
        m_, m, threads,
        [&](std::size_t r, std::size_t& c, double& s, double& d) {
            const double* row = block.F.data() + r * n;
            c = 0;
            s = d = 0.0;
            for (std::size_t j = 0; j < n; ++j) {
                const double v = row[j];
                s += v;
                if (v > t)
                    ++c;
                else
                    d += v;
            }
        },
        [&](std::size_t r, std::size_t k) {
            const double* row = block.F.data() + r * n;
            const double* err = se ? block.standard_error->data() + r * n : nullptr;
            for (std::size_t j = 0; j < n; ++j) {
                if (!(row[j] > t)) continue;
                m_.values[k] = row[j];
                m_.indices[k] = static_cast<std::int32_t>(j);
                if (se) (*m_.standard_error)[k] = err[j];
                ++k;
            }
        });
}

void SparseRows::reset(std::size_t first, std::size_t rows, bool standard_errors) {
    first_row = first;
    indices.assign(rows, {});
    values.assign(rows, {});
    standard_error.assign(standard_errors ? rows : 0, {});
}

namespace {

// Rows [r0, r1) of `block` appended to `out` (the threshold t; standard errors when se).
void append_sparse_rows(SparseFormFactors& out, const SparseRows& block, std::size_t r0,
                        std::size_t r1, int threads, double t, bool se) {
    const std::size_t n = out.n;
    append_rows(
        out, r1 - r0, threads,
        [&](std::size_t r, std::size_t& c, double& s, double& d) {
            const std::vector<double>& v = block.values[r0 + r];
            const std::vector<std::int32_t>& idx = block.indices[r0 + r];
            if (idx.size() != v.size() || (se && block.standard_error[r0 + r].size() != v.size()))
                throw Error("SparseBuilder: a row's arrays differ in length");
            c = 0;
            s = d = 0.0;
            for (std::size_t k = 0; k < v.size(); ++k) {
                if (idx[k] < 0 || static_cast<std::size_t>(idx[k]) >= n ||
                    (k > 0 && idx[k] <= idx[k - 1]))
                    throw Error("SparseBuilder: a row's columns must ascend within [0, N)");
                s += v[k];
                if (v[k] > t)
                    ++c;
                else
                    d += v[k];
            }
        },
        [&](std::size_t r, std::size_t k) {
            const std::vector<double>& v = block.values[r0 + r];
            for (std::size_t e = 0; e < v.size(); ++e) {
                if (!(v[e] > t)) continue;
                out.values[k] = v[e];
                out.indices[k] = block.indices[r0 + r][e];
                if (se) (*out.standard_error)[k] = block.standard_error[r0 + r][e];
                ++k;
            }
        });
}

// The rows of `block` checked for appending to `m` rows of a matrix of n: true with standard
// errors.
bool check_block(const SparseFormFactors& m, std::size_t rows, const SparseRows& block) {
    if (block.first_row != rows || rows + block.size() > m.n)
        throw Error("SparseBuilder: blocks must come in row order");
    const bool se = m.standard_error.has_value();
    if (se && !block.has_standard_errors())
        throw Error("SparseBuilder: the block has no standard errors");
    return se;
}

}  // namespace

void SparseBuilder::append(const SparseRows& block, int threads) {
    const bool se = check_block(m_, rows(), block);
    append_sparse_rows(m_, block, 0, block.size(), threads, m_.threshold, se);
}

void SparseBuilder::append(SparseRows&& block, int threads) {
    const bool se = check_block(m_, rows(), block);
    const std::size_t m = block.size();
    // Room for every stored entry at once (pages the rows do not reach until they are written).
    std::size_t stored = 0;
    for (std::size_t r = 0; r < m; ++r)
        for (const double v : block.values[r]) stored += v > m_.threshold ? 1 : 0;
    if (m_.values.capacity() < m_.values.size() + stored) reserve(m_.values.size() + stored);
    // In chunks of rows, each chunk's rows released once it is in the matrix.
    constexpr std::size_t kChunks = 16;
    const std::size_t chunk = std::max<std::size_t>(1, (m + kChunks - 1) / kChunks);
    for (std::size_t r0 = 0; r0 < m; r0 += chunk) {
        const std::size_t r1 = std::min(m, r0 + chunk);
        append_sparse_rows(m_, block, r0, r1, threads, m_.threshold, se);
        for (std::size_t r = r0; r < r1; ++r) {
            std::vector<std::int32_t>().swap(block.indices[r]);
            std::vector<double>().swap(block.values[r]);
            if (se) std::vector<double>().swap(block.standard_error[r]);
        }
        release_free_memory();
    }
}

SparseFormFactors SparseBuilder::finish() {
    if (rows() != m_.n)
        throw Error("SparseBuilder: " + std::to_string(rows()) + " of " + std::to_string(m_.n) +
                    " rows appended");
    // No shrink_to_fit: it would copy the arrays (and hold both copies at once) to give back
    // the few percent that reserve() asked for beyond the projection.
    return std::move(m_);
}

SparseFormFactors to_sparse(const FormFactors& ff, double threshold) {
    if (ff.is_block()) throw Error("to_sparse: needs the whole square matrix");
    SparseBuilder b(ff.size(), ff.areas, threshold, ff.standard_error.has_value());
    b.append(ff, 1);
    return b.finish();
}

SparseDiagnostics diagnose(const SparseFormFactors& F) {
    SparseDiagnostics d;
    d.n = F.n;
    d.nonzeros = F.nonzeros();
    if (F.n == 0) return d;
    d.row_sum_min = std::numeric_limits<double>::infinity();
    d.row_sum_max = -d.row_sum_min;
    double total_area = 0.0, dropped_area = 0.0;
    // Seconds for 10^5 rows: a signal must not wait for the end.
    const CancellationFlag& cancel = current_cancellation();
    for (std::size_t i = 0; i < F.n; ++i) {
        cancel.throw_if_requested();
        const double s = F.row_sum(i);
        d.row_sum_min = std::min(d.row_sum_min, s);
        d.row_sum_max = std::max(d.row_sum_max, s);
        d.row_sum_mean += s / static_cast<double>(F.n);
        d.dropped_max = std::max(d.dropped_max, F.dropped[i]);
        total_area += F.areas[i];
        dropped_area += F.areas[i] * F.dropped[i];
        for (auto k = F.indptr[i]; k < F.indptr[i + 1]; ++k) {
            const auto kk = static_cast<std::size_t>(k);
            const std::size_t j = static_cast<std::size_t>(F.indices[kk]);
            const double v = F.values[kk];
            if (!std::isfinite(v)) ++d.nonfinite_entries;
            if (v < 0.0) ++d.negative_entries;
            if (v > 1.0) ++d.entries_above_one;
            if (j == i) {
                ++d.diagonal_entries;
                continue;
            }
            const auto first = F.indices.begin() + F.indptr[j];
            const auto last = F.indices.begin() + F.indptr[j + 1];
            const auto it = std::lower_bound(first, last, static_cast<std::int32_t>(i));
            if (it == last || *it != static_cast<std::int32_t>(i)) {
                ++d.asymmetric_entries;
                if (v != 0.0) d.max_reciprocity_defect = std::max(d.max_reciprocity_defect, 1.0);
                continue;
            }
            const double g = F.areas[i] * v;
            const double h =
                F.areas[j] * F.values[static_cast<std::size_t>(it - F.indices.begin())];
            const double big = std::max(std::abs(g), std::abs(h));
            if (big > 0.0)
                d.max_reciprocity_defect =
                    std::max(d.max_reciprocity_defect, std::abs(g - h) / big);
        }
    }
    d.sky_min = 1.0 - d.row_sum_max;
    d.sky_max = 1.0 - d.row_sum_min;
    d.dropped_area_weighted = total_area > 0.0 ? dropped_area / total_area : 0.0;
    return d;
}

}  // namespace formfactor
