#pragma once
// The unobstructed form factors between polygons, for rows of a matrix or listed pairs: the
// kernels' polygon-to-polygon values with far-field rules, shared by the methods that need F
// without visibility (analytic, mc-target). Not public API.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "formfactor/core/progress.h"
#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/kernels/analytic.h"

namespace formfactor::detail {

/// The patches' normals, centroids, areas, radii and far-field quadrature rules (the low
/// orders stored, the higher ones computed when asked for) that the functions below use: built
/// by each call, or once by make_patch_table() for calls on the same polygons (the blocks of
/// rows and parts of pairs of one scene). About 1 kB a triangle.
struct PatchTable;
std::shared_ptr<const PatchTable> make_patch_table(const std::vector<const Polygon*>& polys,
                                                   int threads);

/// The tolerance of the facing test below for these polygons: 1e-12 of their box's diagonal
/// (vertices that close to a plane count as on it).
double facing_eps(const std::vector<const Polygon*>& polys);
/// Whether the pair (i, j) faces away: one patch behind the other's plane or in it (t: the
/// polygons' table, eps: facing_eps(polys)). Every path here gives such a pair U_ij = 0 by this
/// test, before any kernel, so a caller may leave the pair out and still hold the same values.
bool faces_away(const PatchTable& t, const std::vector<const Polygon*>& polys, std::size_t i,
                std::size_t j, double eps);

/// Counts of the unobstructed entry points: pairs (j > i) facing away (zero), by the far-field
/// rule (far) and by the contour integral (exact); kernel evaluations of the far-field rule and
/// pairs per far-field order.
struct UnobstructedStats {
    std::size_t zero = 0, far = 0, exact = 0;
    std::size_t points = 0;
    std::array<std::size_t, kMaxFarFieldOrder + 1> order_hist{};
};

/// Rows [rows.begin, rows.end) of the unobstructed form factors of the polygons (row i from
/// polys[i]; rows is clamped to the polygons), with the upper-triangle values U_ac (a < c) of
/// every pair that touches the rows. Each unordered pair once: by the double contour integral
/// when near, by the far-field rule when its a-priori error bound is ≤ tol; the lower triangle
/// by reciprocity A_j F_ji = A_i F_ij. Every row (the default RowRange) gives the whole matrix
/// (out.F n × n, out.left empty); a block of rows gives out.F rows.size() × n and out.left the
/// pairs of the rows before it with the block's patches (rows.begin × rows.size()), each value
/// bit for bit the whole matrix's, at the cost of the block's rows plus rows.begin ×
/// rows.size() pairs, not n². With `upper_only`, a block computes only its rows' pairs with
/// later patches: out.F holds F_ij for j > i and 0 elsewhere, out.left is empty (upper() and
/// unobstructed() then answer only for a, s in the block), and the caller fills the rest by
/// reciprocity from the other blocks' rows (F_ij = reciprocal_entry(F_ji, A_j, A_i) for
/// j < i, bit for bit the whole matrix's): the blocks of a matrix then cost n² / 2 together.
/// progress (may be null) advances once per row of the block.
struct UnobstructedBlock {
    RowRange rows;
    std::size_t n = 0;
    DenseMatrix F;
    DenseMatrix left;
    std::vector<double> areas;
    /// U_ac (a < c) of a pair that touches the block.
    double upper(std::size_t a, std::size_t c) const;
    /// The whole matrix's unobstructed F_sr, for a pair that touches the block.
    double unobstructed(std::size_t s, std::size_t r) const;
    /// Sets F_ij when row i is in the block (else nothing: the row is not asked for).
    void set(std::size_t i, std::size_t j, double v) {
        if (rows.contains(i))
            F(static_cast<Eigen::Index>(i - rows.begin), static_cast<Eigen::Index>(j)) = v;
    }
};
UnobstructedStats unobstructed_rows(const std::vector<const Polygon*>& polys, double tol,
                                    int threads, Progress* progress, RowRange rows,
                                    UnobstructedBlock& out, bool upper_only = false,
                                    const PatchTable* table = nullptr);

/// The entry of the lower triangle from the upper one: F_ji = A_i F_ij / A_j (i < j), written
/// once here so that every path (dense, blocks, sparse rows) evaluates it alike.
inline double reciprocal_entry(double upper, double area_i, double area_j) {
    return area_j > 0.0 ? upper * area_i / area_j : 0.0;
}

/// F (n × n, row-major) below the diagonal from above it: F_ji = reciprocal_entry(F_ij, A_i,
/// A_j) for i < j, as the whole matrix of unobstructed_rows() is filled.
void lower_by_reciprocity(double* F, std::size_t n, const std::vector<double>& area, int threads);

/// The unobstructed U_ij of the listed pairs only: for each row i, the columns columns[i] (all
/// > i, ascending) get values[i][k] = U_{i, columns[i][k]}, bit for bit the value
/// unobstructed_rows() gives. Cost: the listed pairs, not n². progress (may be null)
/// advances once per row.
UnobstructedStats unobstructed_pairs(const std::vector<const Polygon*>& polys, double tol,
                                     int threads, Progress* progress,
                                     const std::vector<std::vector<std::int32_t>>& columns,
                                     std::vector<std::vector<double>>& values,
                                     std::vector<double>& areas, const PatchTable* table = nullptr);

}  // namespace formfactor::detail
