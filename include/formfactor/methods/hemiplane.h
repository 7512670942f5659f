#pragma once
/// The hemiplane, or single plane (Sillion & Puech, "A General Two-Pass Method Integrating
/// Specular and Diffuse Reflection", SIGGRAPH 1989): one projection plane parallel to the base
/// of the point, at height 1, bounded to [−W, W]² (W = 10 by default: the height is 0.1 of the
/// half-width). Visibility by divide and conquer over the plane (Warnock): a cell covered by one
/// nearest polygon, or by none, is finished; otherwise it is split in four, down to the finest
/// cells (R per side, --resolution, a power of two), where the polygon at the cell's centre
/// takes it. The delta form factor of every cell at every level is exact: the form factor from
/// the point to the cell's rectangle (Howell B-3 corner terms, summed with signs).
///
/// Error behaviour:
/// - Neglected rim: directions between the plane's rim and the horizon are not seen; their
///   share of the hemisphere is known exactly, hemiplane_neglected_fraction(W) (0.0081 at
///   W = 10). Nothing is credited there, so F_{dA→Aj} can only be low by the part of Aj that
///   lies there.
/// - Discretisation: every finished cell above the finest level is exact. Only the finest cells
///   that stay mixed are decided by their centre, so for every j,
///   |F_{dA→Aj} − exact over the plane| ≤ the sum of the delta form factors of those cells
///   (the "ambiguous" fraction, reported per run). The plane's cells are uniform in the plane,
///   so near the zenith they are W/R of the height wide: 10× coarser there than a hemicube's
///   top face of the same R.
/// - Point-to-area, as for the hemicube: use several points (--points) for near patches.

#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/projection_view.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Default half-width of the plane in units of its height (the height is 0.1 of it).
inline constexpr double kHemiplaneHalfWidth = 10.0;

/// Signed form factor from a differential element at the origin (normal +z) to the rectangle
/// [0, x] × [0, y] of the plane z = 1 (Howell B-3, odd in x and in y):
/// G = 1/(2π) [x/√(1+x²) atan(y/√(1+x²)) + y/√(1+y²) atan(x/√(1+y²))].
double hemiplane_corner_term(double x, double y);

/// Share of the hemisphere that the plane [−W, W]² at height 1 misses: 1 − 4 G(W, W).
double hemiplane_neglected_fraction(double half_width = kHemiplaneHalfWidth);

/// One hemiplane's answer for a point.
struct HemiplaneRow {
    std::vector<double> F;   ///< F_{dA→Aj} for every patch j
    double neglected = 0.0;  ///< hemiplane_neglected_fraction(W)
    double ambiguous = 0.0;  ///< sum of ΔF of the finest cells decided by their centre
};

/// F_{dA→Aj} for every patch from one hemiplane at `point` with base normal `normal`, the plane
/// rotated by `rotation` radians about the normal; `exclude_patch` is not drawn (or −1).
/// Throws OptionError("resolution") unless R is a power of two in [64, 2048].
HemiplaneRow hemiplane_point_row(const Scene& scene, const Vec3& point, const Vec3& normal,
                                 int resolution, double rotation = 0.0, int exclude_patch = -1,
                                 double half_width = kHemiplaneHalfWidth);

/// The item buffer of that hemiplane at its finest cells (see ProjectionView).
ProjectionView hemiplane_view(const Scene& scene, const Vec3& point, const Vec3& normal,
                              int resolution, double rotation = 0.0, int exclude_patch = -1,
                              double half_width = kHemiplaneHalfWidth);

/// The `hemiplane` method. Reads MethodOptions::resolution (finest cells per side, a power of
/// two, 64–2048), points, seed (a random rotation per plane) and threads. Details:
/// neglected_fraction, plane_half_width, ambiguous_max and ambiguous_mean (the discretisation
/// bound per row), resolution, points, hemiplanes.
class HemiplaneMethod final : public Method {
  public:
    explicit HemiplaneMethod(double half_width = kHemiplaneHalfWidth) : half_width_(half_width) {}
    MethodKind kind() const override { return MethodKind::hemiplane; }
    void check(const Scene& scene) const override;
    /// Rows go sparse when asked (MethodContext::sparse_rows): the patches each plane saw.
    bool emits_sparse_rows() const override { return true; }
    MethodResult compute(const MethodContext& ctx) const override;

  private:
    double half_width_;
};

}  // namespace formfactor
