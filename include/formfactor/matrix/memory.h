#pragma once
/// Memory of dense runs, estimated before anything big is allocated (DESIGN.md, "Scale": never
/// silently run out of memory; estimate first, refuse with a message).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace formfactor {

/// What a dense computation holds at its peak, part by part.
struct MemoryEstimate {
    struct Item {
        std::string what;  ///< e.g. "F (135,000² doubles)"
        double bytes = 0;  ///< a double: absurd sizes must not wrap
    };
    std::vector<Item> items;

    void add(std::string what, double bytes) { items.push_back({std::move(what), bytes}); }
    /// Sum of the items.
    double total() const;
};

/// What a dense run of N patches keeps in memory besides F itself.
struct DenseRunNeeds {
    std::size_t patches = 0;       ///< N
    bool matrix = true;            ///< the run holds F, N × N doubles
    bool standard_errors = false;  ///< the method fills FormFactors::standard_error (N² more)
    bool repair = false;           ///< repair() keeps a copy of F (N² more)
    /// Further N × N double matrices alive at the peak, with what they are for (a direct solve's
    /// LU factors, total exchange factors, ...).
    std::vector<std::string> extra_matrices;
    /// M: a further dense M × N output of doubles (point factors), 0 when none.
    std::size_t output_rows = 0;
};

/// Bytes of a dense rows × cols matrix of doubles.
double dense_matrix_bytes(double rows, double cols);

/// Bytes kept per patch besides the matrices: the patch and its polygon, the analytic method's
/// quadrature rules, per-patch tables of the other methods (a rounded upper figure).
inline constexpr double kBytesPerPatch = 8192;

/// The estimate of a dense run: F, its standard errors, the repair copy, the extra matrices, the
/// further output, and kBytesPerPatch per patch. A lower bound for methods whose internal lists
/// grow with the scene's pairs (the obstruction-aware analytic method's partly hidden pairs).
MemoryEstimate estimate_dense_memory(const DenseRunNeeds& needs);

/// Bytes of memory available to a new allocation now: MemAvailable in /proc/meminfo, else
/// sysconf(_SC_AVPHYS_PAGES) × page size, capped by the address-space limit (RLIMIT_AS) when one
/// is set; 0 when unknown.
double available_memory();

/// Largest N whose estimate (with the same needs otherwise) fits in `available` bytes.
std::size_t max_dense_patches(const DenseRunNeeds& needs, double available);

/// Thrown (a ResourceError) when estimate.total() > available, with one message: what is
/// needed (total and parts), what is available, the largest N that fits, and `advice` (what to
/// do instead, in the caller's words). No check when available ≤ 0 (unknown).
void check_memory(const DenseRunNeeds& needs, double available, const std::string& advice);

/// What a sparse run (row blocks of the pipeline thresholded into CSR) holds at its peak.
struct SparseRunNeeds {
    std::size_t patches = 0;       ///< N
    std::size_t block_rows = 0;    ///< m, rows per block
    bool standard_errors = false;  ///< the method fills standard errors (the block's and the CSR's)
    /// The analytic method's block also holds, for the rows before it, their pairs with the
    /// block's patches (≤ N × m doubles).
    bool block_strip = false;
    /// The method builds the whole N × N unobstructed matrix inside, whatever the block
    /// (mc-target today), with its standard errors and an N²/8-byte table of cleared pairs.
    bool whole_matrix_inside = false;
    /// Expected stored entries (0: not known yet; the CSR is then listed as growing).
    double nonzeros = 0;
    /// The repair's working copies (the transposed pattern and the symmetrised matrix).
    bool repair = false;
    /// The method emits its rows sparse (Method::emits_sparse_rows()): no rows × N block, but
    /// per thread a row of N accumulators, and the block's rows until they join the CSR
    /// (`row_entries` expected entries a row, 0: not known yet, counted as 256).
    bool rows_sparse = false;
    double row_entries = 0;
    int threads = 1;
};

/// The estimate of a sparse run: the block buffers, the whole matrix when the method builds it
/// inside, the CSR arrays for `nonzeros` entries, the repair's copies, kBytesPerPatch per patch.
MemoryEstimate estimate_sparse_memory(const SparseRunNeeds& needs);

/// Rows per block so that the block buffers of `needs` (its block_rows ignored) take about
/// `budget` bytes: at least 1, at most N.
std::size_t sparse_block_rows(const SparseRunNeeds& needs, double budget);

/// Throws ResourceError when estimate_sparse_memory(needs).total() > available: what is
/// needed (parts), what is available, and `advice`. No check when available ≤ 0 (unknown).
void check_sparse_memory(const SparseRunNeeds& needs, double available, const std::string& advice);

/// Peak resident memory of this process so far (getrusage ru_maxrss), in bytes; 0 when unknown.
double peak_memory_bytes();

/// Gives the pages of freed heap memory back to the system (glibc's malloc_trim; nothing
/// elsewhere), so that the resident size follows what is held after many small arrays are freed
/// (a method's rows as they join the CSR).
void release_free_memory();

/// A whole number with thousands separators: "135,000".
std::string format_count(double x);

/// "1.5 GB", "730 MB", "12 kB" (powers of 1000).
std::string format_bytes(double bytes);

}  // namespace formfactor
