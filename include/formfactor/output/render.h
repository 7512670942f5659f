#pragma once
/// Pictures of a solution: a software rasteriser for a pinhole camera (z-buffer, perspective-
/// correct interpolation, supersampled), radiosity shading (Gouraud from patch values smoothed
/// to the vertices — area-weighted over the patches of one material meeting at a vertex
/// within a 20° crease angle — or flat), false-colour heat maps with a colour bar, and 3D export
/// with per-vertex colours (PLY, glTF 2.0).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/output/image.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// Options of the renderers.
struct RenderOptions {
    int width = 640;
    int height = 640;
    /// The view; empty = the scene's camera, else auto_camera().
    std::optional<Camera> camera;
    /// Flat shading: each patch in its own value (no smoothing to the vertices).
    bool flat = false;
    /// Linear radiosity is multiplied by this before the sRGB encoding; 0 = automatic (the
    /// 99th percentile of the luminance of the visible non-emitting surfaces maps to 0.9).
    double exposure = 0.0;
    /// Supersampling factor per axis (2 = 2×2 samples per pixel, box-filtered).
    int supersample = 2;
    /// Patches left out of the automatic exposure (the light sources, which clip to white
    /// anyway); empty = none.
    std::vector<bool> emitters;
    /// Draw back faces (dark grey). Off by default: patches are one-sided, and culling the
    /// back faces turns the near walls of a closed room seen from outside into a cutaway.
    bool back_faces = false;
};

/// What a render used.
struct RenderInfo {
    Camera camera;
    double exposure = 0.0;   ///< the multiplier applied (radiosity renders)
    double value_min = 0.0;  ///< the colour bar's range (false-colour renders)
    double value_max = 0.0;
    std::size_t triangles = 0;  ///< triangles drawn (after near-plane clipping)
};

/// A camera that sees the whole scene: looking at the centre of the bounding box from the
/// direction (1, 0.8, 1.6) (or along the mean patch normal for a flat scene), far enough for
/// the bounding sphere to fit a 40° vertical field of view at the given aspect (width/height).
Camera auto_camera(const Scene& scene, double aspect = 1.0);

/// The camera a render uses: options.camera, else scene.camera, else auto_camera().
Camera render_camera(const Scene& scene, const RenderOptions& options);

/// Radiosity picture: `radiance` has one linear RGB value per patch (e.g. the radiosity B).
/// Patches are one-sided: back faces are culled (see RenderOptions::back_faces). Throws Error
/// on a size mismatch or
/// an image size outside 1..16384.
Image render_radiosity(const Scene& scene, const std::vector<Rgb>& radiance,
                       const RenderOptions& options = {}, RenderInfo* info = nullptr);

/// A scalar field to show in false colour.
struct FalseColourField {
    std::vector<double> values;  ///< one per patch; NaN = no value (drawn grey)
    std::string label;           ///< e.g. "temperature"
    std::string unit;            ///< e.g. "K" (may be empty)
    std::optional<double> min;   ///< the colour bar's range; empty = from the values
    std::optional<double> max;
};

/// False-colour picture: values mapped through the perceptual "inferno" colour map (van der
/// Walt & Smith, matplotlib), with a colour bar at the right carrying the label, unit and the
/// min / mid / max numbers. Values are smoothed to the vertices like render_radiosity (unless
/// flat) before the mapping.
Image render_false_colour(const Scene& scene, const FalseColourField& field,
                          const RenderOptions& options = {}, RenderInfo* info = nullptr);

/// The inferno colour map at t ∈ [0, 1] (clamped), as linear-light-free display sRGB in [0, 1].
Rgb colormap_inferno(double t);

/// Per-vertex colours for a 3D export.
struct ExportOptions {
    bool flat = false;  ///< one colour per patch (vertices duplicated per patch)
    /// As RenderOptions::exposure; 0 = automatic: the area-weighted 99th percentile of the
    /// patch luminances (emitters left out) maps to 0.9.
    double exposure = 0.0;
    std::vector<bool> emitters;  ///< as RenderOptions::emitters
    bool binary = true;          ///< PLY: binary little-endian (else ASCII)
};

/// Writes the patches as a triangle mesh with per-vertex sRGB colours: `.ply` (PLY with
/// uchar red/green/blue vertex properties), `.gltf` (glTF 2.0, one embedded base64 buffer,
/// COLOR_0 in linear float as the format requires, KHR_materials_unlit) or `.glb` (binary
/// glTF). `radiance` as for render_radiosity. Throws OptionError("output") for another extension.
void write_mesh(const std::string& path, const Scene& scene, const std::vector<Rgb>& radiance,
                const ExportOptions& options = {});

/// The bytes write_mesh() would write to a file named `path` (its extension picks the format).
std::string encode_mesh(const std::string& path, const Scene& scene,
                        const std::vector<Rgb>& radiance, const ExportOptions& options = {});

/// The bytes of a 3D export (encode_mesh()) of a false-colour field: each value in the inferno
/// colour of its place in the field's finite range (colormap_inferno(), stored linear as the
/// exporters expect), grey where there is no finite value. The range used goes to *lo and *hi
/// (when given).
std::string encode_false_colour_mesh(const std::string& path, const Scene& scene,
                                     const FalseColourField& field, bool flat = false,
                                     double* lo = nullptr, double* hi = nullptr);

/// True when `path` ends in .ply, .gltf or .glb (case-insensitive).
bool is_mesh_path(const std::string& path);

}  // namespace formfactor
