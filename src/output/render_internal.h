#pragma once
// Shared pieces of the renderers and the mesh export.

#include <array>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/output/render.h"
#include "formfactor/scene/scene.h"

namespace formfactor::detail {

/// Triangles of the patches with one value per vertex.
struct ShadedMesh {
    std::vector<Vec3> positions;
    std::vector<Rgb> values;
    std::vector<std::array<int, 3>> triangles;  ///< counter-clockwise about the patch normal
    std::vector<int> triangle_patch;
};

/// Triangulates every patch. Flat: each patch has its own vertices carrying its value.
/// Smooth (Gouraud): the patches that have a corner at the same position, the same material
/// and normals that differ by less than 20° share a vertex, which carries their area-weighted mean
/// value; patches across a crease (the two walls at a corner) never share a vertex, so values are
/// not smeared round corners. NaN patch values are left out of the means.
ShadedMesh shaded_mesh(const Scene& scene, const std::vector<Rgb>& patch_values, bool flat);

/// Rec. 709 luminance of linear RGB.
inline double luminance(const Rgb& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

/// Linear [0, 1] → 8-bit sRGB (IEC 61966-2-1), clamped.
std::uint8_t linear_to_srgb8(double v);
/// Linear → sRGB-encoded value in [0, 1], clamped.
double linear_to_srgb(double v);
/// sRGB-encoded value in [0, 1] → linear (IEC 61966-2-1), the inverse of linear_to_srgb().
double srgb_to_linear(double c);

/// Area-weighted q-quantile of the luminance of the patches (emitters left out); 0 if none.
double patch_luminance_quantile(const Scene& scene, const std::vector<Rgb>& values,
                                const std::vector<bool>& emitters, double q);

/// Draws `text` with its top-left corner at (x, y), glyphs scaled by `scale` (the base font is
/// stb_easy_font's, about 7 px tall).
void draw_text(Image& image, int x, int y, const std::string& text, int scale,
               const std::array<std::uint8_t, 3>& colour);
/// Width in pixels of draw_text(text, scale).
int text_width(const std::string& text, int scale);
/// Height in pixels of one line at `scale`.
int text_height(int scale);

/// Writes bytes to `path` atomically (write_file_atomically: a temporary, then a rename).
void write_bytes_atomically(const std::string& path, const std::string& bytes);

}  // namespace formfactor::detail
