// Conservative repair of sparse form factors (see formfactor/matrix/sparse_repair.h).

#include "formfactor/matrix/sparse_repair.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"

namespace formfactor {

namespace {

// The transposed pattern of F: for column c, the rows r with a stored F_rc, ascending, and
// the position of F_rc in F's arrays.
struct Transposed {
    std::vector<std::int64_t> ptr;
    std::vector<std::int32_t> row;
    std::vector<std::int64_t> pos;
};

Transposed transpose(const SparseFormFactors& F) {
    Transposed t;
    t.ptr.assign(F.n + 1, 0);
    for (const std::int32_t c : F.indices) ++t.ptr[static_cast<std::size_t>(c) + 1];
    for (std::size_t c = 0; c < F.n; ++c) t.ptr[c + 1] += t.ptr[c];
    t.row.resize(F.nonzeros());
    t.pos.resize(F.nonzeros());
    std::vector<std::int64_t> next(t.ptr.begin(), t.ptr.end() - 1);
    for (std::size_t r = 0; r < F.n; ++r)
        for (auto k = F.indptr[r]; k < F.indptr[r + 1]; ++k) {
            const auto c = static_cast<std::size_t>(F.indices[static_cast<std::size_t>(k)]);
            const auto at = static_cast<std::size_t>(next[c]++);
            t.row[at] = static_cast<std::int32_t>(r);
            t.pos[at] = k;
        }
    return t;
}

// F_ij = G_ij d_i d_j / A_i for the entry at position k of row i: one expression for every
// use, so that the row sums checked are the row sums written, bit for bit. d_i d_j is one
// product, so that G_ji d_j d_i gives the same exchange area.
inline double entry(const SparseFormFactors& G, const std::vector<double>& d, std::size_t i,
                    std::int64_t k) {
    const auto kk = static_cast<std::size_t>(k);
    const double g = G.values[kk] * (d[i] * d[static_cast<std::size_t>(G.indices[kk])]);
    return G.areas[i] > 0.0 ? g / G.areas[i] : 0.0;
}

double row_sum(const SparseFormFactors& G, const std::vector<double>& d, std::size_t i) {
    double s = 0.0;
    for (auto k = G.indptr[i]; k < G.indptr[i + 1]; ++k) s += entry(G, d, i, k);
    return s;
}

void row_sums(const SparseFormFactors& G, const std::vector<double>& d, std::vector<double>& out) {
    parallel_for(G.n, 0, [&](std::size_t i) { out[i] = row_sum(G, d, i); });
}

}  // namespace

SparseRepairReport repair(SparseFormFactors& F, const SparseRepairOptions& options) {
    F.check();
    SparseRepairReport rep;
    rep.closure = options.closure;
    rep.before = diagnose(F);
    const std::size_t n = F.n;

    // 1. The union pattern, with symmetric exchange areas G (in a SparseFormFactors whose
    // values are G_ij).
    const Transposed t = transpose(F);
    SparseFormFactors G;
    G.n = n;
    G.areas = F.areas;
    G.indptr.assign(n + 1, 0);
    std::vector<std::size_t> restored(n, 0), removed(n, 0);
    auto merge_row = [&](std::size_t i, auto&& put) {
        auto a = F.indptr[i], a_end = F.indptr[i + 1];
        auto b = t.ptr[i], b_end = t.ptr[i + 1];
        while (a < a_end || b < b_end) {
            const std::int32_t ca = a < a_end ? F.indices[static_cast<std::size_t>(a)]
                                              : std::numeric_limits<std::int32_t>::max();
            const std::int32_t cb = b < b_end ? t.row[static_cast<std::size_t>(b)]
                                              : std::numeric_limits<std::int32_t>::max();
            const std::int32_t c = std::min(ca, cb);
            const auto j = static_cast<std::size_t>(c);
            // g_ij from row i, g_ji from row j (stored at t.pos).
            const bool has_ij = ca == c, has_ji = cb == c;
            const double g_ij = has_ij ? F.areas[i] * F.values[static_cast<std::size_t>(a)] : 0.0;
            const double g_ji =
                has_ji ? F.areas[j] *
                             F.values[static_cast<std::size_t>(t.pos[static_cast<std::size_t>(b)])]
                       : 0.0;
            if (has_ij) ++a;
            if (has_ji) ++b;
            const double g = has_ij && has_ji ? 0.5 * (g_ij + g_ji) : (has_ij ? g_ij : g_ji);
            if (j == i || !(g > 0.0)) {
                if (has_ij) ++removed[i];
                continue;
            }
            if (!has_ij) ++restored[i];
            put(c, g);
        }
    };
    parallel_for(n, 0, [&](std::size_t i) {
        std::int64_t count = 0;
        merge_row(i, [&](std::int32_t, double) { ++count; });
        G.indptr[i + 1] = count;
        restored[i] = removed[i] = 0;
    });
    for (std::size_t i = 0; i < n; ++i) G.indptr[i + 1] += G.indptr[i];
    G.indices.resize(static_cast<std::size_t>(G.indptr[n]));
    G.values.resize(G.indices.size());
    parallel_for(n, 0, [&](std::size_t i) {
        auto k = static_cast<std::size_t>(G.indptr[i]);
        merge_row(i, [&](std::int32_t c, double g) {
            G.indices[k] = c;
            G.values[k] = g;
            ++k;
        });
    });
    for (std::size_t i = 0; i < n; ++i) {
        rep.entries_restored += restored[i];
        rep.entries_removed += removed[i];
    }

    // 2. The symmetric scaling d.
    std::vector<double> d(n, 1.0), sums(n, 0.0);
    if (options.closure) {
        row_sums(G, d, sums);
        for (; rep.closure_iterations < options.max_iterations; ++rep.closure_iterations) {
            double residual = 0.0;
            for (std::size_t i = 0; i < n; ++i)
                if (G.indptr[i + 1] > G.indptr[i])
                    residual = std::max(residual, std::abs(sums[i] - 1.0));
            rep.closure_residual = residual;
            if (residual <= options.closure_tolerance) break;
            // Sinkhorn–Knopp: sums[i] = d_i Σ_j F_ij d_j, so d_i ← d_i / √sums[i].
            for (std::size_t i = 0; i < n; ++i)
                if (sums[i] > 0.0) d[i] /= std::sqrt(sums[i]);
            row_sums(G, d, sums);
        }
        for (std::size_t i = 0; i < n; ++i)
            if (G.indptr[i + 1] == G.indptr[i]) ++rep.rows_not_closable;
    } else {
        // One Gauss–Seidel sweep: rows above their cap scaled to it (with a margin for the
        // rounding of the final products), in order.
        constexpr double kMargin = 1.0 - 1e-14;
        for (std::size_t i = 0; i < n; ++i) {
            const double s = row_sum(G, d, i);
            const double cap = std::max(0.0, F.computed_row_sums[i]);
            if (s > cap) {
                d[i] *= s > 0.0 ? cap * kMargin / s : 0.0;
                ++rep.rows_lowered;
            }
        }
        // Rounding check: lower any row still above its cap (rare; a few passes at most).
        for (int pass = 0; pass < 8; ++pass) {
            row_sums(G, d, sums);
            bool changed = false;
            for (std::size_t i = 0; i < n; ++i) {
                const double cap = std::max(0.0, F.computed_row_sums[i]);
                if (sums[i] > cap) {
                    d[i] *= sums[i] > 0.0 ? (cap / sums[i]) * kMargin : 0.0;
                    changed = true;
                }
            }
            if (!changed) break;
        }
    }
    for (const double x : d) rep.min_scale = std::min(rep.min_scale, x);

    // 3. F from G and d.
    SparseFormFactors out;
    out.n = n;
    out.areas = F.areas;
    out.computed_row_sums = F.computed_row_sums;
    out.threshold = F.threshold;
    out.dropped.assign(n, 0.0);
    out.values.resize(G.values.size());
    parallel_for(n, 0, [&](std::size_t i) {
        double s = 0.0;
        for (auto k = G.indptr[i]; k < G.indptr[i + 1]; ++k) {
            const double f = entry(G, d, i, k);
            out.values[static_cast<std::size_t>(k)] = f;
            s += f;
        }
        out.dropped[i] = out.computed_row_sums[i] - s;
    });
    out.indptr = std::move(G.indptr);
    out.indices = std::move(G.indices);
    rep.max_row_increase = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i)
        rep.max_row_increase = std::max(rep.max_row_increase, -out.dropped[i]);
    if (n == 0) rep.max_row_increase = 0.0;
    F = std::move(out);
    rep.after = diagnose(F);
    return rep;
}

}  // namespace formfactor
