// Pictures: render() → an H×W×3 uint8 array, optionally written as a PNG (atomically).

#include <fmt/format.h>

#include "bindings.h"
#include "formfactor/core/error.h"
#include "formfactor/output/render.h"
#include "formfactor/solve/properties.h"

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

py::array_t<std::uint8_t> render(const PyScene& s, const py::object& values,
                                 const py::object& width, const py::object& height,
                                 const std::string& path, const py::object& flat,
                                 const py::object& exposure, const py::object& label_arg,
                                 const py::object& unit_arg, const py::object& vmin,
                                 const py::object& vmax, const py::object& camera,
                                 const py::object& supersample, const py::object& back_faces) {
    const Scene& scene = *s.scene;
    const std::size_t n = scene.patches.size();
    const std::string label = arg<std::string>(label_arg, "label");
    const std::string unit = arg<std::string>(unit_arg, "unit");
    RenderOptions o;
    o.width = arg<int>(width, "width");
    o.height = arg<int>(height, "height");
    o.flat = arg<bool>(flat, "flat");
    o.exposure = arg<double>(exposure, "exposure");
    o.supersample = arg<int>(supersample, "supersample");
    o.back_faces = arg<bool>(back_faces, "back_faces");
    if (!camera.is_none()) {
        if (!py::isinstance<py::dict>(camera))
            throw OptionError("camera", "must be a dict (eye, target, up, fov), got " +
                                            py::repr(camera).cast<std::string>());
        o.camera = camera_of(camera.cast<py::dict>());
    }
    const PatchProperties props = properties_from_scene(scene);
    o.emitters.resize(n);
    for (std::size_t i = 0; i < n; ++i) o.emitters[i] = props.emission[i].maxCoeff() > 0.0;

    Image image;
    if (values.is_none()) {
        // A preview of the geometry: each patch in its reflectance (emitters in their emission).
        std::vector<Rgb> colour(n);
        for (std::size_t i = 0; i < n; ++i)
            colour[i] = o.emitters[i] ? props.emission[i] : props.reflectance[i];
        py::gil_scoped_release nogil;
        image = render_radiosity(scene, colour, o);
    } else {
        const auto a =
            py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
        if (!a) throw OptionError("values", "must be an array of numbers");
        if (a.ndim() == 2 && a.shape(1) == 3 && static_cast<std::size_t>(a.shape(0)) == n) {
            std::vector<Rgb> rad(n);
            for (std::size_t i = 0; i < n; ++i)
                rad[i] = Rgb(a.data()[3 * i], a.data()[3 * i + 1], a.data()[3 * i + 2]);
            py::gil_scoped_release nogil;
            image = render_radiosity(scene, rad, o);
        } else if (a.ndim() == 1 && static_cast<std::size_t>(a.shape(0)) == n) {
            FalseColourField f;
            f.values.assign(a.data(), a.data() + n);
            f.label = label;
            f.unit = unit;
            if (!vmin.is_none()) f.min = arg<double>(vmin, "vmin");
            if (!vmax.is_none()) f.max = arg<double>(vmax, "vmax");
            py::gil_scoped_release nogil;
            image = render_false_colour(scene, f, o);
        } else {
            throw OptionError("values", fmt::format("must have shape ({0}, 3) (RGB radiosity) or "
                                                    "({0},) (a value per patch, false colour)",
                                                    n));
        }
    }
    if (!path.empty()) write_png(path, image);
    py::array_t<std::uint8_t> out({static_cast<std::size_t>(image.height),
                                   static_cast<std::size_t>(image.width), std::size_t(3)});
    std::copy(image.rgb.begin(), image.rgb.end(), out.mutable_data());
    return out;
}

}  // namespace

void bind_render(py::module_& m) {
    m.def("render", &render, py::arg("scene"), py::arg("values"), py::arg("width"),
          py::arg("height"), py::arg("path"), py::arg("flat"), py::arg("exposure"),
          py::arg("label"), py::arg("unit"), py::arg("vmin"), py::arg("vmax"), py::arg("camera"),
          py::arg("supersample"), py::arg("back_faces"));
}

}  // namespace formfactor::python
