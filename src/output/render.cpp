#include "formfactor/output/render.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "formfactor/core/error.h"
#include "output/render_internal.h"

namespace formfactor {

namespace {

Bounds3 scene_bounds(const Scene& scene) {
    Bounds3 b;
    for (const Surface& s : scene.surfaces)
        for (const Vec3& v : s.polygon.vertices) b.extend(v);
    for (const Patch& p : scene.patches)
        for (const Vec3& v : p.polygon.vertices) b.extend(v);
    return b;
}

// Camera frame and projection to supersampled pixel coordinates.
struct View {
    Vec3 eye, right, up, forward;
    double focal = 1.0;  // pixels per unit of x/z
    double cx = 0.0, cy = 0.0;
    double near = 1e-6;

    View(const Camera& c, int w, int h, double scene_size) {
        eye = c.eye;
        forward = c.target - c.eye;
        if (!(forward.norm() > 0.0) || !forward.allFinite())
            throw OptionError("camera", "the eye and the target coincide");
        forward.normalize();
        right = forward.cross(c.up);
        if (!(right.norm() > 1e-12))
            throw OptionError("camera", "the up vector is parallel to the view direction");
        right.normalize();
        up = right.cross(forward);
        if (!(c.fov_degrees > 0.0 && c.fov_degrees < 179.0))
            throw OptionError("camera", "the field of view must be in (0, 179) degrees");
        focal = 0.5 * h / std::tan(0.5 * c.fov_degrees * kPi / 180.0);
        cx = 0.5 * w;
        cy = 0.5 * h;
        near = 1e-5 * scene_size;
    }
    Vec3 to_camera(const Vec3& p) const {
        const Vec3 d = p - eye;
        return {d.dot(right), d.dot(up), d.dot(forward)};
    }
};

struct ClipVertex {
    Vec3 c;  // camera space (x right, y up, z forward)
    Rgb value;
};

// Sample buffers at the supersampled resolution.
struct Framebuffer {
    int w = 0, h = 0;
    std::vector<Rgb> value;
    std::vector<float> inv_z;  // 0 = background
    std::vector<int> patch;    // −1 = background
    std::vector<std::uint8_t> back;

    Framebuffer(int width, int height)
        : w(width),
          h(height),
          value(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), Rgb::Zero()),
          inv_z(value.size(), 0.0f),
          patch(value.size(), -1),
          back(value.size(), 0) {}
};

// Draws one camera-space triangle (already in front of the near plane): perspective-correct
// interpolation of the value (value/z and 1/z are affine in screen space), z-buffer on 1/z.
void draw_triangle(const View& view, const ClipVertex (&v)[3], int patch, bool back,
                   Framebuffer& fb) {
    double sx[3], sy[3], iz[3];
    for (int k = 0; k < 3; ++k) {
        iz[k] = 1.0 / v[k].c.z();
        sx[k] = view.cx + view.focal * v[k].c.x() * iz[k];
        sy[k] = view.cy - view.focal * v[k].c.y() * iz[k];
    }
    const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
    if (!(std::abs(area) > 1e-12)) return;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({sx[0], sx[1], sx[2]}))));
    const int x1 = std::min(fb.w - 1, static_cast<int>(std::ceil(std::max({sx[0], sx[1], sx[2]}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({sy[0], sy[1], sy[2]}))));
    const int y1 = std::min(fb.h - 1, static_cast<int>(std::ceil(std::max({sy[0], sy[1], sy[2]}))));
    const double inv_area = 1.0 / area;
    for (int y = y0; y <= y1; ++y) {
        const double py = y + 0.5;
        for (int x = x0; x <= x1; ++x) {
            const double px = x + 0.5;
            double w0 =
                ((sx[2] - sx[1]) * (py - sy[1]) - (sy[2] - sy[1]) * (px - sx[1])) * inv_area;
            double w1 =
                ((sx[0] - sx[2]) * (py - sy[2]) - (sy[0] - sy[2]) * (px - sx[2])) * inv_area;
            double w2 = 1.0 - w0 - w1;
            // Inclusive edges: shared edges may be drawn twice (the z-test keeps one), never
            // leave a crack.
            if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
            const double z_inv = w0 * iz[0] + w1 * iz[1] + w2 * iz[2];
            const std::size_t s = static_cast<std::size_t>(y) * static_cast<std::size_t>(fb.w) +
                                  static_cast<std::size_t>(x);
            if (!(z_inv > static_cast<double>(fb.inv_z[s]))) continue;
            fb.inv_z[s] = static_cast<float>(z_inv);
            fb.value[s] =
                (w0 * iz[0] * v[0].value + w1 * iz[1] * v[1].value + w2 * iz[2] * v[2].value) /
                z_inv;
            fb.patch[s] = patch;
            fb.back[s] = back ? 1 : 0;
        }
    }
}

void check_size(const RenderOptions& o) {
    if (o.width < 1 || o.height < 1 || o.width > 16384 || o.height > 16384)
        throw OptionError("size", fmt::format("{}x{} is outside 1..16384", o.width, o.height));
    if (o.supersample < 1 || o.supersample > 8) throw OptionError("supersample", "must be 1..8");
}

// Rasterises the mesh at (w·s)×(h·s) samples.
Framebuffer rasterise(const Scene& scene, const detail::ShadedMesh& mesh, const Camera& camera,
                      int w, int h, bool back_faces, RenderInfo* info) {
    const Bounds3 b = scene_bounds(scene);
    const double size = b.empty() ? 1.0 : std::max(b.diagonal().norm(), 1e-300);
    const View view(camera, w, h, size);
    Framebuffer fb(w, h);
    std::vector<Vec3> cam(mesh.positions.size());
    for (std::size_t k = 0; k < cam.size(); ++k) cam[k] = view.to_camera(mesh.positions[k]);
    std::size_t drawn = 0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const int p = mesh.triangle_patch[t];
        const Patch& patch = scene.patches[static_cast<std::size_t>(p)];
        const auto& tri = mesh.triangles[t];
        const Vec3& a = mesh.positions[static_cast<std::size_t>(tri[0])];
        const bool back = patch.normal.dot(camera.eye - a) <= 0.0;
        if (back && !back_faces) continue;
        // Clip the triangle against the near plane z = near (Sutherland–Hodgman).
        ClipVertex in[3];
        for (int k = 0; k < 3; ++k)
            in[k] = {cam[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])],
                     mesh.values[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])]};
        ClipVertex out[4];
        int m = 0;
        for (int k = 0; k < 3; ++k) {
            const ClipVertex& P = in[k];
            const ClipVertex& Q = in[(k + 1) % 3];
            const double dp = P.c.z() - view.near, dq = Q.c.z() - view.near;
            if (dp >= 0.0) out[m++] = P;
            if ((dp >= 0.0) != (dq >= 0.0)) {
                const double s = dp / (dp - dq);
                out[m++] = {P.c + s * (Q.c - P.c), P.value + s * (Q.value - P.value)};
            }
        }
        for (int k = 1; k + 1 < m; ++k) {
            const ClipVertex tri3[3] = {out[0], out[k], out[k + 1]};
            draw_triangle(view, tri3, p, back, fb);
            ++drawn;
        }
    }
    if (info) {
        info->camera = camera;
        info->triangles = drawn;
    }
    return fb;
}

// Box filter s×s samples into one pixel; `encode` applies the sRGB curve after averaging
// (samples in linear light), otherwise samples are display values already.
template <class F>
void downsample(int w, int h, int s, bool encode, F&& sample_colour, Image& img) {
    img.width = w;
    img.height = h;
    img.rgb.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0);
    const double inv = 1.0 / (s * s);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            Rgb acc = Rgb::Zero();
            for (int j = 0; j < s; ++j)
                for (int i = 0; i < s; ++i) acc += sample_colour(x * s + i, y * s + j);
            acc *= inv;
            std::uint8_t* px = img.pixel(x, y);
            for (int c = 0; c < 3; ++c)
                px[c] = encode ? detail::linear_to_srgb8(acc[c])
                               : static_cast<std::uint8_t>(
                                     std::lround(255.0 * std::clamp(acc[c], 0.0, 1.0)));
        }
}

void check_values(const Scene& scene, std::size_t values) {
    if (values != scene.patches.size())
        throw Error(fmt::format(
            "render: {} values for {} patches (same scene and subdivision as the solution?)",
            values, scene.patches.size()));
}

}  // namespace

Camera auto_camera(const Scene& scene, double aspect) {
    const Bounds3 b = scene_bounds(scene);
    Camera c;
    if (b.empty()) return c;
    const Vec3 centre = 0.5 * (b.lo + b.hi);
    const double radius = std::max(0.5 * b.diagonal().norm(), 1e-12);
    Vec3 m = Vec3::Zero();
    double total = 0.0;
    for (const Patch& p : scene.patches) {
        m += p.area * p.normal;
        total += p.area;
    }
    Vec3 dir(1.0, 0.8, 1.6);
    if (total > 0.0 && (m / total).norm() > 0.3) {
        // Mostly facing one way (a flat scene): look at the fronts, slightly from the side.
        const Vec3 n = m.normalized();
        Vec3 u, v;
        orthonormal_basis(n, u, v);
        dir = n + 0.35 * u + 0.25 * v;
    }
    dir.normalize();
    c.fov_degrees = 40.0;
    const double half_v = 0.5 * c.fov_degrees * kPi / 180.0;
    const double half_h = std::atan(std::tan(half_v) * std::max(aspect, 1e-3));
    const double dist = 1.05 * radius / std::sin(std::min(half_v, half_h));
    c.eye = centre + dist * dir;
    c.target = centre;
    c.up = std::abs(dir.y()) > 0.95 ? Vec3::UnitZ() : Vec3::UnitY();
    return c;
}

Camera render_camera(const Scene& scene, const RenderOptions& options) {
    if (options.camera) return *options.camera;
    if (scene.camera) return *scene.camera;
    return auto_camera(scene, static_cast<double>(options.width) / options.height);
}

Image render_radiosity(const Scene& scene, const std::vector<Rgb>& radiance,
                       const RenderOptions& options, RenderInfo* info) {
    check_size(options);
    check_values(scene, radiance.size());
    const int s = options.supersample;
    const Camera camera = render_camera(scene, options);
    const detail::ShadedMesh mesh = detail::shaded_mesh(scene, radiance, options.flat);
    RenderInfo local;
    const Framebuffer fb = rasterise(scene, mesh, camera, options.width * s, options.height * s,
                                     options.back_faces, &local);
    double exposure = options.exposure;
    if (!(exposure > 0.0)) {
        // 99th percentile of the visible, front-facing, non-emitting samples → 0.9.
        std::vector<double> lum;
        lum.reserve(fb.value.size() / 4);
        for (std::size_t k = 0; k < fb.value.size(); ++k) {
            const int p = fb.patch[k];
            if (p < 0 || fb.back[k]) continue;
            if (static_cast<std::size_t>(p) < options.emitters.size() &&
                options.emitters[static_cast<std::size_t>(p)])
                continue;
            const double y = detail::luminance(fb.value[k]);
            if (std::isfinite(y)) lum.push_back(y);
        }
        double q = 0.0;
        if (!lum.empty()) {
            const std::size_t at = static_cast<std::size_t>(0.99 * (lum.size() - 1));
            std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(at), lum.end());
            q = lum[at];
        }
        exposure = q > 0.0 ? 0.9 / q : 1.0;
    }
    const Rgb back_grey = Rgb::Constant(0.03);  // linear: a dark grey
    Image img;
    downsample(
        options.width, options.height, s, true,
        [&](int x, int y) -> Rgb {
            const std::size_t k = static_cast<std::size_t>(y) * static_cast<std::size_t>(fb.w) +
                                  static_cast<std::size_t>(x);
            if (fb.patch[k] < 0) return Rgb::Zero();
            if (fb.back[k]) return back_grey;
            return (exposure * fb.value[k]).cwiseMax(0.0).cwiseMin(1.0);
        },
        img);
    local.exposure = exposure;
    if (info) *info = local;
    return img;
}

Rgb colormap_inferno(double t) {
    // Degree-6 minimax polynomial fit of matplotlib's inferno (van der Walt & Smith), by Matt
    // Zucker (shadertoy WlfXRN, CC0).
    t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
    static const Rgb c[7] = {{0.0002189403691192265, 0.001651004631001012, -0.01948089843709184},
                             {0.1065134194856116, 0.5639564367884091, 3.932712388889277},
                             {11.60249308247187, -3.972853965665698, -15.9423941062914},
                             {-41.70399613139459, 17.43639888205313, 44.35414519872813},
                             {77.162935699427, -33.40235894210092, -81.80730925738993},
                             {-71.31942824499214, 32.62606426397723, 73.20951985803202},
                             {25.13112622477341, -12.24266895238567, -23.07032500287172}};
    Rgb r = c[6];
    for (int k = 5; k >= 0; --k) r = c[k] + t * r;
    return r.cwiseMax(0.0).cwiseMin(1.0);
}

Image render_false_colour(const Scene& scene, const FalseColourField& field,
                          const RenderOptions& options, RenderInfo* info) {
    check_size(options);
    check_values(scene, field.values.size());
    // Range of the colour bar.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double v : field.values)
        if (std::isfinite(v)) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
    if (!std::isfinite(lo)) lo = hi = 0.0;
    if (field.min) lo = *field.min;
    if (field.max) hi = *field.max;
    const double span = hi > lo ? hi - lo : 1.0;

    // Layout: the scene on the left, a panel with the colour bar on the right.
    const int W = options.width, H = options.height;
    const int scale = std::max(1, H / 320);
    const auto label = [](double v) { return fmt::format("{:.4g}", v); };
    std::string title = field.label;
    if (!field.unit.empty()) title += " [" + field.unit + "]";
    const int pad = 6 * scale;
    const int bar_w = 14 * scale;
    int labels_w = 0;
    for (double v : {lo, 0.5 * (lo + hi), hi})
        labels_w = std::max(labels_w, detail::text_width(label(v), scale));
    const int panel = std::min(W / 2, std::max(pad + bar_w + pad + labels_w + pad,
                                               detail::text_width(title, scale) + 2 * pad));
    const int view_w = std::max(1, W - panel);

    std::vector<Rgb> vals(field.values.size());
    for (std::size_t i = 0; i < vals.size(); ++i) vals[i] = Rgb::Constant(field.values[i]);
    const int s = options.supersample;
    RenderOptions view_opts = options;
    view_opts.width = view_w;
    const Camera camera = render_camera(scene, view_opts);
    const detail::ShadedMesh mesh = detail::shaded_mesh(scene, vals, options.flat);
    RenderInfo local;
    const Framebuffer fb =
        rasterise(scene, mesh, camera, view_w * s, H * s, options.back_faces, &local);
    Image view;
    downsample(
        view_w, H, s, false,
        [&](int x, int y) -> Rgb {
            const std::size_t k = static_cast<std::size_t>(y) * static_cast<std::size_t>(fb.w) +
                                  static_cast<std::size_t>(x);
            if (fb.patch[k] < 0) return Rgb::Constant(0.25);  // grey: inferno starts at black
            if (fb.back[k]) return Rgb::Constant(0.3);
            const double v = fb.value[k][0];
            if (!std::isfinite(v)) return Rgb::Constant(0.5);
            return colormap_inferno((v - lo) / span);
        },
        view);
    Image img;
    img.width = W;
    img.height = H;
    img.rgb.assign(static_cast<std::size_t>(W) * static_cast<std::size_t>(H) * 3, 64);
    for (int y = 0; y < H; ++y) std::copy_n(view.pixel(0, y), 3 * view_w, img.pixel(0, y));
    // Panel: title, bar (max at the top), three labels.
    if (W - view_w >= 1) {
        const std::array<std::uint8_t, 3> white{235, 235, 235};
        const int x_bar = view_w + pad;
        const int th = detail::text_height(scale);
        const int y_top = pad + th + pad + th / 2;
        const int y_bot = H - pad - th / 2;
        detail::draw_text(img, view_w + pad, pad, title, scale, white);
        if (y_bot > y_top) {
            for (int y = y_top; y <= y_bot; ++y) {
                const double t = 1.0 - static_cast<double>(y - y_top) / (y_bot - y_top);
                const Rgb c = colormap_inferno(t);
                for (int x = x_bar; x < std::min(W, x_bar + bar_w); ++x) {
                    std::uint8_t* px = img.pixel(x, y);
                    for (int ch = 0; ch < 3; ++ch)
                        px[ch] = static_cast<std::uint8_t>(std::lround(255.0 * c[ch]));
                }
            }
            const int x_lab = x_bar + bar_w + pad;
            detail::draw_text(img, x_lab, y_top - th / 2, label(hi), scale, white);
            detail::draw_text(img, x_lab, (y_top + y_bot) / 2 - th / 2, label(0.5 * (lo + hi)),
                              scale, white);
            detail::draw_text(img, x_lab, y_bot - th / 2, label(lo), scale, white);
        }
    }
    local.value_min = lo;
    local.value_max = hi;
    if (info) *info = local;
    return img;
}

}  // namespace formfactor
