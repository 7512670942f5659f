#pragma once
/// What one point sees through a projection method (hemicube or hemiplane): the item buffer
/// laid out for display, with the delta form factor of every cell. Used by `formfactor
/// inspect`, by output/view_image.h and by tests. It holds patch indices and nothing of the
/// methods that fill it, so it lives with the scene, where output/ may draw it.

#include <vector>

namespace formfactor {

/// Item of a cell that sees nothing (background: the ray leaves the scene).
inline constexpr int kViewNothing = -1;
/// Item of a cell that sees the back of a patch: it blocks, but receives no form factor.
inline constexpr int kViewBackFace = -2;
/// Item of a cell that sees an obstruction-only surface (it blocks from both sides).
inline constexpr int kViewObstruction = -3;
/// Item of a pixel of the layout that is no cell (the corners of the unfolded hemicube).
inline constexpr int kViewUnused = -4;

/// A projection's item buffer as an image, row 0 at the top.
///
/// Hemicube (Cohen & Greenberg 1985), resolution R: a 2R × 2R cross, the top face (R × R) in
/// the middle and the four half side faces (R × R/2) unfolded around it, so that the image is
/// continuous across the cube's edges. In the local frame of the point (u, v, w = normal) the
/// image's right is +u and its top +v; the right arm is the +u side face, its outer edge the
/// horizon.
///
/// Hemiplane (Sillion & Puech 1989), resolution R: the R × R finest cells of the plane parallel
/// to the base at height 1, covering [−W, W]² in units of that height; right is +u, top +v.
struct ProjectionView {
    enum class Kind { hemicube, hemiplane };
    Kind kind = Kind::hemicube;
    int resolution = 0;  ///< R, cells per side of the top face or the plane
    int width = 0;       ///< pixels per image row
    int height = 0;      ///< image rows
    /// Per pixel: a patch index (≥ 0) or kViewNothing / kViewBackFace / kViewObstruction /
    /// kViewUnused. Row-major, width × height.
    std::vector<int> items;
    /// Per pixel: the delta form factor of its cell (0 on unused pixels). Hemicube: normalised
    /// so the whole cube sums to 1. Hemiplane: exact integrals over the cell, summing to
    /// 1 − neglected.
    std::vector<double> delta;
    /// Hemiplane: the fraction of the hemisphere outside the plane (0 for the hemicube).
    double neglected = 0.0;

    int item(int col, int row) const { return items[static_cast<std::size_t>(row) * width + col]; }
};

}  // namespace formfactor
