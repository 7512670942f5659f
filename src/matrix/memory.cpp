#include "formfactor/matrix/memory.h"

#include <fmt/format.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/matrix/sparse.h"

namespace formfactor {

double MemoryEstimate::total() const {
    double t = 0.0;
    for (const Item& i : items) t += i.bytes;
    return t;
}

double dense_matrix_bytes(double rows, double cols) { return rows * cols * sizeof(double); }

std::string format_count(double x) {
    const std::string digits = fmt::format("{:.0f}", x);
    std::string out;
    const std::size_t n = digits.size();
    for (std::size_t k = 0; k < n; ++k) {
        if (k > 0 && digits[k - 1] != '-' && (n - k) % 3 == 0) out += ',';
        out += digits[k];
    }
    return out;
}

MemoryEstimate estimate_dense_memory(const DenseRunNeeds& needs) {
    MemoryEstimate e;
    const double n = static_cast<double>(needs.patches);
    const double nn = dense_matrix_bytes(n, n);
    const std::string square = format_count(n) + "² doubles";
    if (needs.matrix) e.add("F (" + square + ")", nn);
    if (needs.standard_errors) e.add("standard errors (" + square + ")", nn);
    if (needs.repair) e.add("repair copy of F (" + square + ")", nn);
    for (const std::string& what : needs.extra_matrices) e.add(what + " (" + square + ")", nn);
    if (needs.output_rows > 0)
        e.add(fmt::format("output ({} × {} doubles)", format_count(double(needs.output_rows)),
                          format_count(n)),
              dense_matrix_bytes(double(needs.output_rows), n));
    e.add("patches and per-patch tables", n * kBytesPerPatch);
    return e;
}

double available_memory() {
    double avail = 0.0;
    {
        std::ifstream in("/proc/meminfo");
        std::string line;
        while (std::getline(in, line)) {
            if (line.rfind("MemAvailable:", 0) != 0) continue;
            std::istringstream s(line.substr(13));
            double kb = 0.0;
            std::string unit;
            if (s >> kb) avail = kb * 1024.0;
            break;
        }
    }
    if (!(avail > 0.0)) {
        const long pages = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGESIZE);
        if (pages > 0 && size > 0) avail = static_cast<double>(pages) * static_cast<double>(size);
    }
    struct rlimit rl {};
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
        const double limit = static_cast<double>(rl.rlim_cur);
        avail = avail > 0.0 ? std::min(avail, limit) : limit;
    }
    return avail;
}

std::size_t max_dense_patches(const DenseRunNeeds& needs, double available) {
    // total(N) = a N² + b N with a = bytes per N² (the square matrices), b = kBytesPerPatch
    // plus the M × N output's M doubles.
    double a = 0.0;
    {
        DenseRunNeeds one = needs;
        one.patches = 1;
        one.output_rows = 0;
        a = estimate_dense_memory(one).total() - kBytesPerPatch;
    }
    const double b = kBytesPerPatch + static_cast<double>(needs.output_rows) * sizeof(double);
    if (!(available > 0.0)) return 0;
    const double n =
        a > 0.0 ? (-b + std::sqrt(b * b + 4.0 * a * available)) / (2.0 * a) : available / b;
    return n > 0.0 ? static_cast<std::size_t>(std::floor(n)) : 0;
}

namespace {

/// "F 8.0 GB, standard errors 8.0 GB": the items of `e` that are at least 1 % of its total.
std::string main_items(const MemoryEstimate& e) {
    const double total = e.total();
    std::string parts;
    for (const MemoryEstimate::Item& i : e.items) {
        if (i.bytes < 0.01 * total) continue;
        parts += (parts.empty() ? "" : ", ") + i.what + " " + format_bytes(i.bytes);
    }
    return parts;
}

}  // namespace

void check_memory(const DenseRunNeeds& needs, double available, const std::string& advice) {
    if (!(available > 0.0)) return;
    const MemoryEstimate e = estimate_dense_memory(needs);
    const double total = e.total();
    if (total <= available) return;
    const std::string parts = main_items(e);
    std::string msg = fmt::format(
        "not enough memory: {} patches need about {} ({}), this machine has {} available",
        format_count(double(needs.patches)), format_bytes(total), parts, format_bytes(available));
    const std::size_t fit = max_dense_patches(needs, available);
    msg += fmt::format("; at most about {} patches fit", format_count(double(fit)));
    if (!advice.empty()) msg += ": " + advice;
    throw ResourceError(msg);
}

namespace {

// Bytes of the block buffers per row of a block.
double block_bytes_per_row(const SparseRunNeeds& needs) {
    const double n = static_cast<double>(needs.patches);
    if (needs.rows_sparse) {
        const double entries = needs.row_entries > 0 ? needs.row_entries : 256.0;
        const double per_entry =
            sizeof(std::int32_t) + sizeof(double) * (needs.standard_errors ? 2 : 1);
        return 3 * sizeof(std::vector<double>) + entries * per_entry;
    }
    double per_row = dense_matrix_bytes(1, n) * (needs.standard_errors ? 2 : 1);
    if (needs.block_strip) per_row += dense_matrix_bytes(1, n);
    return per_row;
}

}  // namespace

MemoryEstimate estimate_sparse_memory(const SparseRunNeeds& needs) {
    MemoryEstimate e;
    const double n = static_cast<double>(needs.patches);
    const double m = static_cast<double>(needs.block_rows);
    if (needs.rows_sparse) {
        e.add(fmt::format("a block of {} rows emitted sparse", format_count(m)),
              m * block_bytes_per_row(needs));
        e.add(
            fmt::format("a row of {} accumulators per thread ({} threads)", format_count(n),
                        needs.threads),
            double(std::max(needs.threads, 1)) * n * (sizeof(std::uint32_t) + 2 * sizeof(double)));
    } else {
        e.add(fmt::format("a block of {} rows ({} × {} doubles{}{})", format_count(m),
                          format_count(m), format_count(n),
                          needs.standard_errors ? ", with standard errors" : "",
                          needs.block_strip ? ", and the strip of earlier rows' pairs" : ""),
              m * block_bytes_per_row(needs));
    }
    if (needs.whole_matrix_inside) {
        const double nn = dense_matrix_bytes(n, n);
        e.add(fmt::format("the whole unobstructed matrix and its standard errors, which the method "
                          "builds for every block ({}² doubles, twice)",
                          format_count(n)),
              2 * nn + n * n / 8);
    }
    if (needs.nonzeros > 0) {
        e.add(fmt::format("CSR of {} entries", format_count(needs.nonzeros)),
              sparse_matrix_bytes(n, needs.nonzeros, needs.standard_errors));
        if (needs.repair)
            e.add("repair's transposed pattern and symmetrised copy",
                  needs.nonzeros * (sizeof(std::int32_t) + sizeof(std::int64_t) +
                                    sizeof(std::int32_t) + 2 * sizeof(double)) +
                      (n + 1) * sizeof(std::int64_t) * 2);
    }
    e.add("patches and per-patch tables", n * kBytesPerPatch);
    return e;
}

std::size_t sparse_block_rows(const SparseRunNeeds& needs, double budget) {
    const double per_row = block_bytes_per_row(needs);
    const double m = per_row > 0.0 ? std::floor(budget / per_row) : double(needs.patches);
    const double clamped = std::clamp(m, 1.0, std::max(1.0, double(needs.patches)));
    return static_cast<std::size_t>(clamped);
}

void check_sparse_memory(const SparseRunNeeds& needs, double available, const std::string& advice) {
    if (!(available > 0.0)) return;
    const MemoryEstimate e = estimate_sparse_memory(needs);
    const double total = e.total();
    if (total <= available) return;
    const std::string parts = main_items(e);
    std::string msg = fmt::format(
        "not enough memory: the sparse run of {} patches needs about {} ({}), this machine has {} "
        "available",
        format_count(double(needs.patches)), format_bytes(total), parts, format_bytes(available));
    if (!advice.empty()) msg += ": " + advice;
    throw ResourceError(msg);
}

double peak_memory_bytes() {
    struct rusage ru {};
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0.0;
    return static_cast<double>(ru.ru_maxrss) * 1024.0;  // kilobytes on Linux
}

void release_free_memory() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

std::string format_bytes(double bytes) {
    const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
    int u = 0;
    double x = bytes;
    while (std::abs(x) >= 1000.0 && u < 6) {
        x /= 1000.0;
        ++u;
    }
    if (u == 0) return fmt::format("{:.0f} bytes", x);
    return fmt::format("{:.{}f} {}", x, x < 10.0 ? 1 : 0, units[u]);
}

}  // namespace formfactor
