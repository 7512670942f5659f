#pragma once
/// The hemicube's item-buffer rasteriser (private). One instance per worker: its buffers are
/// allocated once and reused for every hemicube.

#include <cstdint>
#include <vector>

#include "methods/projection/projection_common.h"

namespace formfactor::projection {

/// The delta form factors in single precision, the four identical side faces stored once
/// (the working set of a hemicube then fits in a core's cache at R = 256).
class HemicubeDelta {
  public:
    /// From hemicube_delta_form_factors(resolution).
    HemicubeDelta(const std::vector<double>& delta, int resolution);
    const float* top() const { return top_.data(); }
    const float* side() const { return side_.data(); }

  private:
    std::vector<float> top_, side_;
};

/// Z-buffer and item buffer of the five faces of a hemicube of resolution R, in the layout of
/// hemicube_delta_form_factors(): top R × R, then +u, −u, +v, −v, each (R/2) × R.
class HemicubeRaster {
  public:
    explicit HemicubeRaster(int resolution);

    /// Draws every occluder seen from the frame's origin above its base plane. `exclude` is an
    /// item not to draw (the patch the point lies on) or −1; `near` the near-plane distance;
    /// occluders whose plane passes within `edge_on` of the origin are skipped.
    void render(const Occluders& occ, const Frame& frame, int exclude, double near, double edge_on);

    /// row[item] += weight · Σ delta[cell] over the cells each patch owns, after render();
    /// row has `patches` entries (the Occluders' patch count).
    void accumulate(const HemicubeDelta& delta, double weight, double* row, std::size_t patches);

    /// Cells of padding after the last face (the SIMD span fill may touch them).
    static constexpr std::size_t kPadding = 8;
    /// The item of every cell (and kPadding cells of padding at the end).
    const std::vector<int>& items() const { return items_; }
    /// The patches the last render() drew (accumulate() credits exactly these).
    const std::vector<int>& touched() const { return touched_; }
    int resolution() const { return R_; }
    std::size_t cells() const { return cells_; }
    /// Offset of face f (0 top, 1 +u, 2 −u, 3 +v, 4 −v) in the buffers.
    std::size_t face_offset(int f) const;

  private:
    void draw(int face, const P3* poly, int n, const double nl[3], double dl, int item);
    void raster(int face, const double* X, const double* Y, int n, double wx, double wy, double w0,
                int item);

    int R_;
    int H_;
    std::size_t cells_;
    std::vector<float> depth_;  // inverse depth along the face axis; 0 = nothing
    std::vector<int> items_;
    std::vector<double> partial_;       // scratch of accumulate(), zero between calls
    std::vector<int> touched_;          // patches drawn by the last render()
    std::vector<std::uint32_t> stamp_;  // per patch: the render() that last drew it
    std::uint32_t epoch_ = 0;
};

/// One face of the hemicube in local coordinates p = (a, b, c): face coordinates
/// U = su·p[iu], V = sv·p[iv], depth D = sd·p[id].
struct HemicubeFace {
    int iu, iv, id;
    double su, sv, sd;
    bool top;
};
/// Top, +u, −u, +v, −v.
inline constexpr HemicubeFace kHemicubeFaces[5] = {
    {0, 1, 2, 1, 1, 1, true},   {1, 2, 0, 1, 1, 1, false},  {1, 2, 0, -1, 1, -1, false},
    {0, 2, 1, -1, 1, 1, false}, {0, 2, 1, 1, 1, -1, false},
};

}  // namespace formfactor::projection
