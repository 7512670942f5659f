#pragma once
/// The hemicube (Cohen & Greenberg, "The Hemi-Cube", SIGGRAPH 1985): around a point on patch i,
/// the upper half of a cube of half-width 1; every other patch and every obstruction-only surface
/// is projected onto its five faces (top R × R cells, four sides R × R/2), clipped and
/// z-buffered; each cell keeps the nearest surface (item buffer), and
/// F_{dAi→Aj} ≈ Σ of the delta form factors of the cells that j owns.
///
/// Error behaviour:
/// - Aliasing: a cell is owned by the surface at its centre, so every edge of a projected
///   patch misassigns up to half a cell; the error falls as 1/R for a single patch (the
///   misassigned cells are along its outline) and partly cancels between neighbours. A random
///   rotation about the normal per hemicube (seeded from (seed, i, k)) breaks the alignment of
///   the cube with the scene, so errors do not add up coherently over rows.
/// - Point-to-area: F_ij is the mean of F_{dAi→Aj} at K points of patch i (the centroid by
///   default). For near patches (distance comparable to the patch size, e.g. adjacent walls)
///   F_{dA→Aj} varies strongly over patch i and one point is not enough: use --points.
/// - Every surface blocks from both sides: a patch seen from behind owns its cells as a back
///   face (no credit), an obstruction-only surface as an obstruction.
/// - Sizes below 1e-9 of the scene's diameter from the point (the near plane) are not seen.

#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/projection_view.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// The delta form factors of a hemicube of (even) resolution R, normalised so that they sum to
/// 1. Layout: the top face, R rows × R cells (cell (X, Y) centred at u = (2X+1)/R − 1,
/// v = (2Y+1)/R − 1, ΔF ∝ ΔA / (π (u² + v² + 1)²)), then the side faces +u, −u, +v, −v, each
/// R/2 rows × R cells (cell (X, Y) centred at s = (2X+1)/R − 1 across, height z = (2Y+1)/R,
/// ΔF ∝ z ΔA / (π (s² + z² + 1)²)), ΔA = (2/R)². Throws OptionError("resolution") when R is
/// odd or outside [64, 2048].
std::vector<double> hemicube_delta_form_factors(int resolution);

/// F_{dA→Aj} for every patch j of `scene` from one hemicube at `point`, base normal `normal`
/// (unit or not), the cube rotated by `rotation` radians about the normal. `exclude_patch` (the
/// patch the point lies on, or −1) is not drawn. Unoccluded parts count; obstructions block.
std::vector<double> hemicube_point_row(const Scene& scene, const Vec3& point, const Vec3& normal,
                                       int resolution, double rotation = 0.0,
                                       int exclude_patch = -1);

/// The item buffer of that hemicube as an unfolded cross (see ProjectionView).
ProjectionView hemicube_view(const Scene& scene, const Vec3& point, const Vec3& normal,
                             int resolution, double rotation = 0.0, int exclude_patch = -1);

/// The `hemicube` method. Reads MethodOptions::resolution (even, 64–2048), points (hemicubes
/// per patch, averaged with area weights), seed (rotations) and threads. Rows run in parallel,
/// each worker owning its buffers; the thread count never changes a result. Details:
/// resolution, points, hemicubes, cells.
class HemicubeMethod final : public Method {
  public:
    MethodKind kind() const override { return MethodKind::hemicube; }
    void check(const Scene& scene) const override;
    /// Rows go sparse when asked (MethodContext::sparse_rows): the patches each hemicube drew.
    bool emits_sparse_rows() const override { return true; }
    MethodResult compute(const MethodContext& ctx) const override;
};

}  // namespace formfactor
