// Pictures: render() → an H×W×3 uint8 array, optionally written as a PNG (atomically).

#include <fmt/format.h>

#include "bindings.h"
#include "formfactor/core/error.h"
#include "formfactor/output/render.h"
#include "formfactor/solve/properties.h"
#include "keywords.h"

namespace formfactor::python {

namespace {

Camera camera_of(const py::dict& d) {
    Camera c;
    auto vec = [&](const char* key, Vec3& v) {
        if (!d.contains(key)) return;
        const std::vector<Vec3> x = as_vec3s(d[key], "camera", 1);
        v = x.front();
    };
    vec("eye", c.eye);
    vec("target", c.target);
    vec("up", c.up);
    if (d.contains("fov")) c.fov_degrees = arg<double>(d["fov"], "camera");
    for (const auto& item : d) {
        const std::string k = py::str(item.first).cast<std::string>();
        if (k != "eye" && k != "target" && k != "up" && k != "fov")
            throw OptionError("camera", "unknown key '" + k + "' (eye, target, up, fov)");
    }
    return c;
}

/// What the keywords of render() set.
struct RenderArgs {
    RenderOptions options;
    /// The colour bar of a value per patch (label, unit, min, max; the values come later).
    FalseColourField field;
    std::string path;
};

/// The arguments of render(), in order.
const Keyword<RenderArgs> kRenderKeywords[] = {
    {"scene", "Scene", nullptr, "the scene to draw.", nullptr, true},
    {"values", "Optional[_ArrayLike]", "None",
     "None (each patch in its material's colour), an (N, 3) radiosity (linear RGB, exposed "
     "automatically unless exposure > 0), or an (N,) value per patch shown in false colour "
     "(inferno) with a colour bar.",
     nullptr, true},
    {"width", "int", "640", "pixels.",
     [](const py::object& v, RenderArgs& o) { o.options.width = arg<int>(v, "width"); }},
    {"height", "int", "640", "pixels.",
     [](const py::object& v, RenderArgs& o) { o.options.height = arg<int>(v, "height"); }},
    {"path", "Union[None, str, PathLike[str]]", "None",
     "also write the picture there as a PNG (atomically).",
     [](const py::object& v, RenderArgs& o) { o.path = path_arg(v); }},
    {"flat", "bool", "False", "each patch in its own value (no smoothing to the vertices).",
     [](const py::object& v, RenderArgs& o) { o.options.flat = arg<bool>(v, "flat"); }},
    {"exposure", "float", "0.0",
     "linear radiosity is multiplied by this before the sRGB encoding; 0: automatic.",
     [](const py::object& v, RenderArgs& o) { o.options.exposure = arg<double>(v, "exposure"); }},
    {"label", "str", "''", "the colour bar's label (false colour).",
     [](const py::object& v, RenderArgs& o) { o.field.label = arg<std::string>(v, "label"); }},
    {"unit", "str", "''", "the colour bar's unit (false colour).",
     [](const py::object& v, RenderArgs& o) { o.field.unit = arg<std::string>(v, "unit"); }},
    {"vmin", "Optional[float]", "None", "the colour bar's low end (default: the values' least).",
     [](const py::object& v, RenderArgs& o) { o.field.min = arg<double>(v, "vmin"); }},
    {"vmax", "Optional[float]", "None",
     "the colour bar's high end (default: the values' greatest).",
     [](const py::object& v, RenderArgs& o) { o.field.max = arg<double>(v, "vmax"); }},
    {"camera", "Optional[dict[str, Any]]", "None",
     "{\"eye\": (x, y, z), \"target\": ..., \"up\": ..., \"fov\": degrees}; default: the "
     "scene's camera or one that sees everything.",
     [](const py::object& v, RenderArgs& o) {
         if (!py::isinstance<py::dict>(v))
             throw OptionError("camera", "must be a dict (eye, target, up, fov), got " +
                                             py::repr(v).cast<std::string>());
         o.options.camera = camera_of(v.cast<py::dict>());
     }},
    {"supersample", "int", "2", "samples per pixel along each axis (box-filtered).",
     [](const py::object& v, RenderArgs& o) {
         o.options.supersample = arg<int>(v, "supersample");
     }},
    {"back_faces", "bool", "False",
     "draw back faces (dark grey); off: a closed room seen from outside shows its inside.",
     [](const py::object& v, RenderArgs& o) { o.options.back_faces = arg<bool>(v, "back_faces"); }},
};

const Signature<RenderArgs> kRender{
    "render", "np.ndarray",
    "A picture of the scene: an (height, width, 3) uint8 sRGB array, also written as a PNG to "
    "``path`` when given.",
    kRenderKeywords};

py::array_t<std::uint8_t> render(RenderArgs& a, const std::vector<py::object>& values) {
    const Scene& scene = *scene_arg(value_of(kRender, values, "scene")).scene;
    const py::object& shown = value_of(kRender, values, "values");
    const std::size_t n = scene.patches.size();
    RenderOptions& o = a.options;
    const PatchProperties props = properties_from_scene(scene);
    o.emitters.resize(n);
    for (std::size_t i = 0; i < n; ++i) o.emitters[i] = props.emission[i].maxCoeff() > 0.0;

    Image image;
    if (shown.is_none()) {
        // A preview of the geometry: each patch in its reflectance (emitters in their emission).
        std::vector<Rgb> colour(n);
        for (std::size_t i = 0; i < n; ++i)
            colour[i] = o.emitters[i] ? props.emission[i] : props.reflectance[i];
        py::gil_scoped_release nogil;
        image = render_radiosity(scene, colour, o);
    } else {
        const auto v =
            py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(shown);
        if (!v) throw OptionError("values", "must be an array of numbers");
        if (v.ndim() == 2 && v.shape(1) == 3 && static_cast<std::size_t>(v.shape(0)) == n) {
            std::vector<Rgb> rad(n);
            for (std::size_t i = 0; i < n; ++i)
                rad[i] = Rgb(v.data()[3 * i], v.data()[3 * i + 1], v.data()[3 * i + 2]);
            py::gil_scoped_release nogil;
            image = render_radiosity(scene, rad, o);
        } else if (v.ndim() == 1 && static_cast<std::size_t>(v.shape(0)) == n) {
            FalseColourField& f = a.field;
            f.values.assign(v.data(), v.data() + n);
            py::gil_scoped_release nogil;
            image = render_false_colour(scene, f, o);
        } else {
            throw OptionError("values", fmt::format("must have shape ({0}, 3) (RGB radiosity) or "
                                                    "({0},) (a value per patch, false colour)",
                                                    n));
        }
    }
    if (!a.path.empty()) write_png(a.path, image);
    py::array_t<std::uint8_t> out({static_cast<std::size_t>(image.height),
                                   static_cast<std::size_t>(image.width), std::size_t(3)});
    std::copy(image.rgb.begin(), image.rgb.end(), out.mutable_data());
    return out;
}

}  // namespace

void bind_render(py::module_& m) { bind_function_with_keywords(m, kRender, render); }

}  // namespace formfactor::python
