// The unobstructed form factors of polygon pairs: every unordered pair once, exactly (double
// contour integral) when near, by a tensor Gauss rule with an a-priori error bound when far; the
// other entry of the pair by reciprocity.

#include "kernels/unobstructed.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/kernels/analytic.h"
#include "kernels/analytic_internal.h"

namespace formfactor::detail {

// The far-field rules of the orders up to this one are stored (30 points a triangle, ~1 kB),
// the higher ones computed when a pair asks for them: every order stored took ~6.5 kB a
// triangle (70 MB at 10⁴ patches), and computing the low orders, which most pairs take, costs
// more than their kernel sums (room n = 24: 6 % of the time with every order computed).
constexpr int kStoredOrders = 4;

/// Per-patch data of the far-field path, flat: the geometry, how each patch's quadrature rules
/// lay their points (rule_shape()), and its rules of the low orders.
struct PatchTable {
    std::vector<Vec3> normal, centroid;
    std::vector<double> area, radius, plane_d;
    std::vector<RuleShape> shape;
    // Triangles of the patches laid as kTriangles: patch p's are tris[tri_first[p] ..
    // tri_first[p + 1]) (3 vertex indices each; empty ranges for the other shapes).
    std::vector<std::uint32_t> tri_first;
    std::vector<int> tris;
    // Patch p's rules of orders 1..kStoredOrders, one after another from points[first[p]].
    std::vector<std::size_t> first;
    RulePoints points;

    std::size_t triangles(std::size_t p) const { return tri_first[p + 1] - tri_first[p]; }
    /// The number of points of patch p's rule of order n.
    std::size_t count(std::size_t p, int n) const {
        const auto nn = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
        switch (shape[p]) {
            case RuleShape::kEmpty:
                return 0;
            case RuleShape::kTriangles:
                return triangles(p) * nn;
            default:
                return nn;
        }
    }
    /// Patch p's stored rule of order n ≤ kStoredOrders.
    RuleView stored(std::size_t p, int n) const {
        std::size_t at = first[p];
        for (int o = 1; o < n; ++o) at += count(p, o);
        return points.view(at, count(p, n));
    }
    /// Appends patch p's rule of order n (polygon_rule(), bit for bit) to `out`: copied when
    /// stored, else computed there.
    void append(const Polygon& poly, std::size_t p, int n, RulePoints& out) const {
        if (n > kStoredOrders) {
            append_rule(poly, shape[p], tris.data() + 3 * std::size_t{tri_first[p]}, triangles(p),
                        n, out);
            return;
        }
        const RuleView r = stored(p, n);
        out.x.insert(out.x.end(), r.x, r.x + r.count);
        out.y.insert(out.y.end(), r.y, r.y + r.count);
        out.z.insert(out.z.end(), r.z, r.z + r.count);
        out.w.insert(out.w.end(), r.w, r.w + r.count);
    }
    /// Patch p's rule of order n: stored, or computed into `scratch` (cleared first).
    RuleView rule(const Polygon& poly, std::size_t p, int n, RulePoints& scratch) const {
        if (n <= kStoredOrders) return stored(p, n);
        scratch.clear();
        append(poly, p, n, scratch);
        return scratch.view(0, scratch.size());
    }
};

namespace {

PatchTable build_table(const std::vector<const Polygon*>& polys, int threads) {
    const std::size_t n = polys.size();
    PatchTable t;
    t.normal.resize(n);
    t.centroid.resize(n);
    t.area.resize(n);
    t.radius.resize(n);
    t.plane_d.resize(n);
    t.shape.resize(n);
    parallel_for(n, threads, [&](std::size_t p) {
        const Polygon& poly = *polys[p];
        t.normal[p] = normal(poly);
        t.centroid[p] = centroid(poly);
        t.area[p] = area(poly);
        t.plane_d[p] = t.normal[p].dot(t.centroid[p]);
        double r = 0.0;
        for (const Vec3& v : poly.vertices) r = std::max(r, (v - t.centroid[p]).norm());
        t.radius[p] = r;
        t.shape[p] = rule_shape(poly);
    });
    t.tri_first.assign(n + 1, 0);
    for (std::size_t p = 0; p < n; ++p) {
        if (t.shape[p] == RuleShape::kTriangles)
            for (const auto& tri : triangulate(*polys[p]))
                t.tris.insert(t.tris.end(), tri.begin(), tri.end());
        if (t.tris.size() / 3 > UINT32_MAX)
            throw ResourceError("analytic: more than 2^32 triangles in the patches' rules");
        t.tri_first[p + 1] = static_cast<std::uint32_t>(t.tris.size() / 3);
    }
    t.first.resize(n + 1);
    t.first[0] = 0;
    for (std::size_t p = 0; p < n; ++p) {
        std::size_t c = 0;
        for (int o = 1; o <= kStoredOrders; ++o) c += t.count(p, o);
        t.first[p + 1] = t.first[p] + c;
    }
    for (std::vector<double>* a : {&t.points.x, &t.points.y, &t.points.z, &t.points.w})
        a->resize(t.first[n]);
    // Each patch's rules into their place (append_rule() appends: through a scratch buffer).
    parallel_for(n, threads, [&](std::size_t p) {
        thread_local RulePoints scratch;
        scratch.clear();
        for (int o = 1; o <= kStoredOrders; ++o)
            append_rule(*polys[p], t.shape[p], t.tris.data() + 3 * std::size_t{t.tri_first[p]},
                        t.triangles(p), o, scratch);
        FF_ASSERT(scratch.size() == t.first[p + 1] - t.first[p]);
        std::copy(scratch.x.begin(), scratch.x.end(), t.points.x.begin() + t.first[p]);
        std::copy(scratch.y.begin(), scratch.y.end(), t.points.y.begin() + t.first[p]);
        std::copy(scratch.z.begin(), scratch.z.end(), t.points.z.begin() + t.first[p]);
        std::copy(scratch.w.begin(), scratch.w.end(), t.points.w.begin() + t.first[p]);
    });
    return t;
}

}  // namespace

void lower_by_reciprocity(double* F, std::size_t n, const std::vector<double>& area, int threads) {
    FF_ASSERT(area.size() == n);
    // In cache-friendly tiles.
    constexpr std::size_t kTile = 64;
    const std::size_t tiles = (n + kTile - 1) / kTile;
    parallel_for(tiles, threads, [&](std::size_t bj) {
        for (std::size_t bi = 0; bi <= bj; ++bi)
            for (std::size_t j = bj * kTile; j < std::min(n, (bj + 1) * kTile); ++j)
                for (std::size_t i = bi * kTile; i < std::min(j, (bi + 1) * kTile); ++i)
                    F[j * n + i] = reciprocal_entry(F[i * n + j], area[i], area[j]);
    });
}

std::shared_ptr<const PatchTable> make_patch_table(const std::vector<const Polygon*>& polys,
                                                   int threads) {
    return std::make_shared<const PatchTable>(build_table(polys, threads));
}

namespace {

enum class Side { kFront, kBehind, kStraddles };

// Where polygon q lies relative to the plane (n, d): a sphere test first, vertices if needed.
// Vertices within eps of the plane count as on it (both sides).
Side side_of(const Vec3& n, double d, const Vec3& c, double r, const Polygon& q, double eps) {
    const double s = n.dot(c) - d;
    if (s - r > eps) return Side::kFront;
    if (s + r <= eps) return Side::kBehind;
    bool front = false, behind = false;
    for (const Vec3& v : q.vertices) {
        const double dv = n.dot(v) - d;
        if (dv > eps) front = true;
        if (dv < -eps) behind = true;
    }
    if (!front) return Side::kBehind;  // behind or in the plane: nothing to see
    return behind ? Side::kStraddles : Side::kFront;
}

using RowStats = UnobstructedStats;

}  // namespace

namespace {

// The unobstructed pairs (i, j) of row i for j in [j_begin, j_end) (all j > i): zero when one
// faces away (nothing emitted), the far-field rule when its bound allows, else the contour
// integral; emit(j, U_ij) for every other pair. One code path for the whole matrix and for a
// block of rows, so that a block holds the whole matrix's values bit for bit (a far-field
// batch computes each pair independently of the others queued with it).
// The columns j ∈ [begin, end) of a row, or a list of them (row_pairs() takes either).
struct ColumnRange {
    std::size_t begin, end;
    template <class F>
    void each(const F& f) const {
        for (std::size_t j = begin; j < end; ++j) f(j);
    }
};
struct ColumnList {
    const std::int32_t* cols;
    std::size_t count;
    template <class F>
    void each(const F& f) const {
        for (std::size_t k = 0; k < count; ++k) f(static_cast<std::size_t>(cols[k]));
    }
};

template <class Cols, class Emit>
void row_pairs(const PatchTable& t, const std::vector<const Polygon*>& polys, double tol,
               double eps, std::size_t i, const Cols& columns, RowStats& st, const Emit& emit) {
    const Vec3& ni = t.normal[i];
    const Vec3& ci = t.centroid[i];
    thread_local FarFieldBatch batch;
    batch.reset();
    columns.each([&](std::size_t j) {
        const Vec3& nj = t.normal[j];
        const Vec3& cj = t.centroid[j];
        const Side sj = side_of(ni, t.plane_d[i], cj, t.radius[j], *polys[j], eps);
        if (sj == Side::kBehind) {
            ++st.zero;
            return;
        }
        const Side si = side_of(nj, t.plane_d[j], ci, t.radius[i], *polys[i], eps);
        if (si == Side::kBehind) {
            ++st.zero;
            return;
        }
        if (sj == Side::kFront && si == Side::kFront) {
            const double d = (cj - ci).norm();
            const double ri = t.radius[i], rj = t.radius[j];
            const double dmin = d - ri - rj;
            if (dmin > 0.0) {
                const double pref = std::max(t.area[i], t.area[j]) * kInvPi / (dmin * dmin);
                const int oi =
                    gauss_order_for_fast(pref, ri / (d - rj), 0.5 * tol, kMaxFarFieldOrder);
                const int oj = oi == 0 ? 0
                                       : gauss_order_for_fast(pref, rj / (d - ri), 0.5 * tol,
                                                              kMaxFarFieldOrder);
                if (oi > 0 && oj > 0) {
                    batch.add(oi, j, nj, cj,
                              [&](RulePoints& out) { t.append(*polys[j], j, oj, out); });
                    ++st.far;
                    st.points += t.count(i, oi) * t.count(j, oj);
                    ++st.order_hist[static_cast<std::size_t>(std::max(oi, oj))];
                    return;
                }
            }
        }
        emit(j, std::max(0.0, polygon_to_polygon(*polys[i], *polys[j])));
        ++st.exact;
    });
    // The row's own rule, once per order it is asked for.
    thread_local RulePoints row_rule;
    batch.run([&](int order) { return t.rule(*polys[i], i, order, row_rule); }, ni, ci,
              1.0 / t.area[i], [&](std::size_t j, double fij) { emit(j, std::max(0.0, fij)); });
}

Bounds3 polygons_box(const std::vector<const Polygon*>& polys) {
    Bounds3 box;
    for (const Polygon* p : polys)
        for (const Vec3& v : p->vertices) box.extend(v);
    return box;
}

}  // namespace

double facing_eps(const std::vector<const Polygon*>& polys) {
    const Bounds3 box = polygons_box(polys);
    return box.empty() ? 0.0 : 1e-12 * box.diagonal().norm();
}

bool faces_away(const PatchTable& t, const std::vector<const Polygon*>& polys, std::size_t i,
                std::size_t j, double eps) {
    return side_of(t.normal[i], t.plane_d[i], t.centroid[j], t.radius[j], *polys[j], eps) ==
               Side::kBehind ||
           side_of(t.normal[j], t.plane_d[j], t.centroid[i], t.radius[i], *polys[i], eps) ==
               Side::kBehind;
}

namespace {

RowStats sum_stats(const std::vector<RowStats>& stats) {
    RowStats total;
    for (const RowStats& s : stats) {
        total.zero += s.zero;
        total.far += s.far;
        total.exact += s.exact;
        total.points += s.points;
        for (std::size_t o = 0; o < total.order_hist.size(); ++o)
            total.order_hist[o] += s.order_hist[o];
    }
    return total;
}

// The table given, else one built here in `own`.
const PatchTable& table_for(const std::vector<const Polygon*>& polys, int threads,
                            const PatchTable* given, std::optional<PatchTable>& own) {
    if (given) {
        FF_ASSERT(given->area.size() == polys.size());
        return *given;
    }
    return own.emplace(build_table(polys, threads));
}

UnobstructedStats whole_matrix(const std::vector<const Polygon*>& polys, double tol, int threads,
                               Progress* progress, DenseMatrix& out_F, std::vector<double>& areas,
                               const PatchTable* table) {
    const std::size_t n = polys.size();
    out_F = DenseMatrix::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
    std::optional<PatchTable> own;
    const PatchTable& t = table_for(polys, threads, table, own);
    areas = t.area;
    const double eps = facing_eps(polys);

    std::vector<RowStats> stats(n);
    double* F = out_F.data();
    // Upper triangle: row i computes F_ij for j > i (each entry written by one task).
    parallel_for(n, threads, [&](std::size_t i) {
        row_pairs(t, polys, tol, eps, i, ColumnRange{i + 1, n}, stats[i],
                  [&](std::size_t j, double v) { F[i * n + j] = v; });
        if (progress) progress->advance();
    });
    lower_by_reciprocity(F, n, t.area, threads);
    return sum_stats(stats);
}

UnobstructedStats row_block(const std::vector<const Polygon*>& polys, double tol, int threads,
                            Progress* progress, RowRange rows, UnobstructedBlock& out,
                            bool upper_only, const PatchTable* table) {
    const std::size_t n = polys.size(), e = rows.end, m = rows.size();
    const std::size_t b = rows.begin, left_rows = upper_only ? 0 : b;
    std::optional<PatchTable> own;
    const PatchTable& t = table_for(polys, threads, table, own);
    out.rows = rows;
    out.n = n;
    out.areas = t.area;
    out.F = DenseMatrix::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(n));
    out.left =
        DenseMatrix::Zero(static_cast<Eigen::Index>(left_rows), static_cast<Eigen::Index>(m));
    const double eps = facing_eps(polys);

    // Rows before the block compute their pairs with the block's patches (into `left`; not
    // with upper_only), the block's rows their pairs with every later patch (into F's upper
    // part).
    std::vector<RowStats> stats(e);
    parallel_for(e - b + left_rows, threads, [&](std::size_t k) {
        const std::size_t r = k < left_rows ? k : b + (k - left_rows);
        if (r < b) {
            double* L = out.left.data() + r * m;
            row_pairs(t, polys, tol, eps, r, ColumnRange{b, e}, stats[r],
                      [&](std::size_t j, double v) { L[j - b] = v; });
        } else {
            double* row = out.F.data() + (r - b) * n;
            row_pairs(t, polys, tol, eps, r, ColumnRange{r + 1, n}, stats[r],
                      [&](std::size_t j, double v) { row[j] = v; });
            if (progress) progress->advance();
        }
    });
    // The block's entries below the diagonal, by reciprocity from the upper values (the
    // caller's, with upper_only).
    if (upper_only) return sum_stats(stats);
    parallel_for(m, threads, [&](std::size_t k) {
        const std::size_t i = b + k;
        double* row = out.F.data() + k * n;
        for (std::size_t j = 0; j < i; ++j)
            row[j] = reciprocal_entry(out.upper(j, i), t.area[j], t.area[i]);
    });
    return sum_stats(stats);
}

}  // namespace

UnobstructedStats unobstructed_rows(const std::vector<const Polygon*>& polys, double tol,
                                    int threads, Progress* progress, RowRange rows,
                                    UnobstructedBlock& out, bool upper_only,
                                    const PatchTable* table) {
    const std::size_t n = polys.size();
    rows = rows.clamped(n);
    if (rows.size() < n)
        return row_block(polys, tol, threads, progress, rows, out, upper_only, table);
    out.rows = rows;
    out.n = n;
    out.left = DenseMatrix::Zero(0, static_cast<Eigen::Index>(n));
    return whole_matrix(polys, tol, threads, progress, out.F, out.areas, table);
}

UnobstructedStats unobstructed_pairs(const std::vector<const Polygon*>& polys, double tol,
                                     int threads, Progress* progress,
                                     const std::vector<std::vector<std::int32_t>>& columns,
                                     std::vector<std::vector<double>>& values,
                                     std::vector<double>& areas, const PatchTable* table) {
    const std::size_t n = polys.size();
    FF_ASSERT(columns.size() == n);
    std::optional<PatchTable> own;
    const PatchTable& t = table_for(polys, threads, table, own);
    areas = t.area;
    const double eps = facing_eps(polys);
    values.assign(n, {});
    std::vector<RowStats> stats(n);
    parallel_for(n, threads, [&](std::size_t i) {
        const std::vector<std::int32_t>& cols = columns[i];
        std::vector<double>& row = values[i];
        row.assign(cols.size(), 0.0);
        if (!cols.empty()) {
            // Emitted in any order (the far-field batch last): placed by column.
            row_pairs(t, polys, tol, eps, i, ColumnList{cols.data(), cols.size()}, stats[i],
                      [&](std::size_t j, double v) {
                          const auto at = std::lower_bound(cols.begin(), cols.end(),
                                                           static_cast<std::int32_t>(j));
                          row[static_cast<std::size_t>(at - cols.begin())] = v;
                      });
        }
        if (progress) progress->advance();
    });
    return sum_stats(stats);
}

double UnobstructedBlock::upper(std::size_t a, std::size_t c) const {
    const std::size_t b = rows.begin, m = rows.size();
    if (rows.contains(a)) return F(static_cast<Eigen::Index>(a - b), static_cast<Eigen::Index>(c));
    FF_ASSERT(a < b && rows.contains(c));
    return left.data()[a * m + (c - b)];
}

double UnobstructedBlock::unobstructed(std::size_t s, std::size_t r) const {
    return s < r ? upper(s, r) : reciprocal_entry(upper(r, s), areas[r], areas[s]);
}

}  // namespace formfactor::detail
