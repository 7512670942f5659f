#pragma once
/// Private machinery shared by the projection methods (hemicube, hemiplane): the occluder
/// arrays built once per scene, the points and frames of the projections, the seeded random
/// streams and convex clipping in the local frame of a point.

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "formfactor/core/parallel.h"
#include "formfactor/core/progress.h"
#include "formfactor/core/types.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/projection_view.h"
#include "formfactor/scene/scene.h"

namespace formfactor::projection {

/// splitmix64 finaliser: a good 64-bit mixing function.
inline std::uint64_t mix64(std::uint64_t x) {
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

/// A uniform number in [0, 1) that depends only on (seed, i, k): the rotation of hemicube k of
/// row i. The thread count never changes it.
inline double stream_uniform(std::uint64_t seed, std::uint64_t i, std::uint64_t k) {
    const std::uint64_t h = mix64(mix64(mix64(seed) ^ (i * 0xd1b54a32d192ed03ULL)) ^ k);
    return static_cast<double>(h >> 11) * 0x1.0p-53;
}

/// Largest number of vertices of a primitive stored as one convex polygon.
inline constexpr int kMaxPrimitiveVertices = 8;
/// Room for a primitive clipped by up to 6 planes.
inline constexpr int kMaxClippedVertices = kMaxPrimitiveVertices + 8;

/// Every surface that can block a view, as convex primitives in flat arrays (structure of
/// arrays): patches (item = patch index) and obstruction-only surfaces (item =
/// kViewObstruction). Convex polygons of up to kMaxPrimitiveVertices vertices stay whole; the
/// rest are triangulated.
struct Occluders {
    std::vector<double> x, y, z;        ///< vertices; primitive p owns [first[p], first[p+1])
    std::vector<std::uint32_t> first;   ///< size() + 1 offsets
    std::vector<int> item;              ///< patch index, or kViewObstruction
    std::vector<double> nx, ny, nz, d;  ///< unit front normal and offset: n·p = d on the plane
    std::vector<double> cx, cy, cz, r;  ///< bounding sphere
    double scale = 1.0;                 ///< diameter of the scene's bounds (> 0)
    std::size_t patches = 0;            ///< the scene's patch count (items are below it)

    std::size_t size() const { return item.size(); }
};

/// Builds the occluder arrays of a scene. Degenerate polygons are skipped.
Occluders build_occluders(const Scene& scene);

/// A point of a patch with its quadrature weight (weights of a patch sum to 1).
struct WeightedPoint {
    Vec3 x;
    double weight;
};

/// K points of a polygon for the point-to-area average: the centroid for K = 1; otherwise the
/// Gauss–Legendre product rule with ns × nt = K nodes in the parameters of the quad's bilinear
/// map (a triangle is a quad with a repeated vertex), weighted by the map's Jacobian; the
/// factors are those whose ratio is closest to the quad's aspect ratio (a 4 × 1 strip gets
/// 8 × 2 of K = 16). The point-to-area average is a smooth integral: for the C-11 plates the
/// 4 × 4 rule is off by 1.5e-6 where 4 × 4 cell centres are off by 1.9e-3. Polygons of more
/// than 4 vertices are triangulated and the points shared out by area; when there are more
/// triangles than K (a many-sided disk), the polygon is cut by recursive area bisection into K
/// compact cells, one point each (the cell's centroid): K points whatever the vertex count.
std::vector<WeightedPoint> patch_points(const Polygon& polygon, int K);

/// The local frame of a projection: origin at the point, w the unit normal of the base plane,
/// (u, v, w) right-handed and orthonormal, rotated by `rotation` radians about w.
struct Frame {
    Vec3 origin, u, v, w;
};
Frame make_frame(const Vec3& point, const Vec3& normal, double rotation);

/// make_frame for a point given by the caller: throws GeometryError("<method>: ...") unless
/// the point and the normal are finite and the normal non-zero.
Frame point_frame(const char* method, const Vec3& point, const Vec3& normal, double rotation);

/// The unit front normal of a patch: its stored normal, else the polygon's.
Vec3 patch_normal(const Patch& p);

/// Throws GeometryError("<method>: patch i is degenerate (no normal)") for the first patch
/// with fewer than 3 vertices or no normal.
void check_patch_normals(const Scene& scene, const char* method);

/// An n × n zero matrix with the patches' areas (stored area, else the polygon's).
FormFactors zero_form_factors(const Scene& scene, RowRange rows);

/// A point in local coordinates (a along u, b along v, c along w: the height above the base).
struct P3 {
    double v[3];
};

/// A clipping plane in local coordinates: inside where na·a + nb·b + nc·c − off ≥ 0.
struct ClipPlane {
    double na, nb, nc, off;
    double distance(const P3& p) const { return na * p.v[0] + nb * p.v[1] + nc * p.v[2] - off; }
};

/// Sutherland–Hodgman clip of the convex polygon in[0..n) by one plane into out; returns the
/// vertex count. The intersection of an edge is computed from its inside end, so two polygons
/// that share an edge get bit-identical clipped vertices on it.
int clip_convex(const P3* in, int n, const ClipPlane& plane, P3* out);

/// Checks --resolution and --points for the projection methods; throws OptionError.
void check_projection_options(int resolution, int points, bool power_of_two);

/// The loop of a projection method's compute(): in parallel over the patches i of ctx.rows
/// (progress phase `label`; `out` holds those rows), for each of the options.points points of patch
/// i, calls visit(worker, i, frame, weight, row) with the point's frame (rotated about the normal
/// by the seeded stream), its weight and row i of out.F; then zeroes F_ii. `worker` is a per-thread
/// Worker made by make() on first use. Returns the number of projections.
template <class Worker, class Make, class Visit>
std::size_t project_patches(const MethodContext& ctx, const char* label, FormFactors& out,
                            Make make, Visit visit) {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const RowRange rows = ctx.rows.clamped(scene.patches.size());
    tbb::enumerable_thread_specific<std::unique_ptr<Worker>> workers;
    std::atomic<std::size_t> projections{0};
    Progress progress(label, rows.size(), ctx.progress);
    parallel_for(rows.size(), options.threads, [&](std::size_t r) {
        const std::size_t i = rows.begin + r;
        std::unique_ptr<Worker>& worker = workers.local();
        if (!worker) worker = make();
        const Patch& p = scene.patches[i];
        const Vec3 nrm = patch_normal(p);
        double* row = out.F.row(static_cast<Eigen::Index>(r)).data();
        const auto points = patch_points(p.polygon, options.points);
        for (std::size_t k = 0; k < points.size(); ++k) {
            const double rotation = 2.0 * kPi * stream_uniform(options.seed, i, k);
            visit(*worker, i, make_frame(points[k].x, nrm, rotation), points[k].weight, row);
        }
        row[i] = 0.0;
        projections.fetch_add(points.size(), std::memory_order_relaxed);
        progress.advance();
    });
    progress.finish();
    return projections.load();
}

/// project_patches() for rows emitted sparse (ctx.sparse_rows, reset to ctx.rows here): the same
/// visits in the same order, into one row of N accumulators per thread instead of a rows × N
/// block; worker.touched() lists the patches the last visit credited, and only those entries
/// are read into the row (columns ascending, zeros left out) and cleared. The entries are the
/// dense rows' bit for bit. Returns the number of projections.
template <class Worker, class Make, class Visit>
std::size_t project_patches_sparse(const MethodContext& ctx, const char* label, Make make,
                                   Visit visit) {
    const Scene& scene = ctx.scene;
    const MethodOptions& options = ctx.options;
    const std::size_t n = scene.patches.size();
    const RowRange rows = ctx.rows.clamped(n);
    SparseRows& out = *ctx.sparse_rows;
    out.reset(rows.begin, rows.size(), false);
    struct Local {
        std::unique_ptr<Worker> worker;
        std::vector<double> acc;  // zero between rows
        std::vector<char> seen;   // zero between rows
        std::vector<std::int32_t> cols;
    };
    tbb::enumerable_thread_specific<Local> locals;
    std::atomic<std::size_t> projections{0};
    Progress progress(label, rows.size(), ctx.progress);
    parallel_for(rows.size(), options.threads, [&](std::size_t r) {
        const std::size_t i = rows.begin + r;
        Local& L = locals.local();
        if (!L.worker) {
            L.worker = make();
            L.acc.assign(n, 0.0);
            L.seen.assign(n, 0);
        }
        const Patch& p = scene.patches[i];
        const Vec3 nrm = patch_normal(p);
        const auto points = patch_points(p.polygon, options.points);
        L.cols.clear();
        for (std::size_t k = 0; k < points.size(); ++k) {
            const double rotation = 2.0 * kPi * stream_uniform(options.seed, i, k);
            visit(*L.worker, i, make_frame(points[k].x, nrm, rotation), points[k].weight,
                  L.acc.data());
            for (const int j : L.worker->touched()) {
                if (j < 0 || L.seen[static_cast<std::size_t>(j)]) continue;
                L.seen[static_cast<std::size_t>(j)] = 1;
                L.cols.push_back(j);
            }
        }
        L.acc[i] = 0.0;
        std::sort(L.cols.begin(), L.cols.end());
        for (const std::int32_t j : L.cols) {
            const auto js = static_cast<std::size_t>(j);
            if (L.acc[js] != 0.0) {
                out.indices[r].push_back(j);
                out.values[r].push_back(L.acc[js]);
            }
            L.acc[js] = 0.0;
            L.seen[js] = 0;
        }
        projections.fetch_add(points.size(), std::memory_order_relaxed);
        progress.advance();
    });
    progress.finish();
    return projections.load();
}

/// A projection method's rows: `out` zeroed for ctx.rows and project_patches() into it, or,
/// when the caller asked for sparse rows (ctx.sparse_rows), `out` without rows (its areas) and
/// project_patches_sparse(). Returns the number of projections.
template <class Worker, class Make, class Visit>
std::size_t project_rows(const MethodContext& ctx, const char* label, FormFactors& out, Make make,
                         Visit visit) {
    const RowRange rows = ctx.rows.clamped(ctx.scene.patches.size());
    if (ctx.sparse_rows) {
        out = zero_form_factors(ctx.scene, RowRange{rows.begin, rows.begin});
        return project_patches_sparse<Worker>(ctx, label, make, visit);
    }
    out = zero_form_factors(ctx.scene, rows);
    return project_patches<Worker>(ctx, label, out, make, visit);
}

/// Twin faces (as Visibility's rule, visibility.h): what cannot take a view — the back of a
/// patch, an obstruction — is drawn as if its plane were this much (relative to the scene's size)
/// farther from the point. The front of a patch coincident with it (a one-sided face modelled
/// back to back with another, a patch lying on an obstruction) then wins the depth test in any
/// drawing order, and is credited; with nothing coincident the back face or obstruction still
/// hides what lies behind it. The same relative offset as VisibilityOptions' ray-end epsilon.
inline constexpr double kRelativeTwinOffset = 1e-5;

/// The offset from the point to an occluder's plane along its unit normal (dl = n·(x − o) for x
/// on the plane), pushed farther by `twin_offset` unless the occluder is the front of a patch.
inline double occluder_plane_offset(double dl, int item, double twin_offset) {
    return item >= 0 ? dl : dl + std::copysign(twin_offset, dl);
}

/// The near distance below which nothing is seen, relative to the scene's size.
inline constexpr double kRelativeNear = 1e-9;
/// Occluders whose plane passes within this distance (relative to the scene's size) of the
/// point are seen edge-on and skipped.
inline constexpr double kRelativeEdgeOn = 1e-12;

}  // namespace formfactor::projection
