// Scenes: formfactor.load(), Scene.from_arrays(), and the per-patch NumPy views.

#include <fmt/format.h>

#include "bindings.h"
#include "formfactor/core/error.h"
#include "formfactor/scene/energyplus.h"
#include "formfactor/scene/merge_coplanar.h"
#include "formfactor/solve/properties.h"
#include "keywords.h"

namespace formfactor::python {

namespace {

SubdivisionOptions subdivision(const py::object& n, const py::object& max_edge) {
    SubdivisionOptions o;
    if (!n.is_none()) o.n = arg<int>(n, "subdivide");
    if (!max_edge.is_none()) o.max_edge = arg<double>(max_edge, "max_edge");
    return o;
}

PyScene finish(Scene scene, const py::object& n, const py::object& max_edge) {
    const SubdivisionOptions o = subdivision(n, max_edge);
    {
        py::gil_scoped_release nogil;
        subdivide(scene, o);
    }
    return PyScene{std::make_shared<const Scene>(std::move(scene))};
}

/// The faces argument of from_arrays: an (F, k) integer array, or a sequence of sequences of
/// vertex indices (polygons of any sizes).
std::vector<std::vector<long long>> face_lists(const py::handle& faces) {
    std::vector<std::vector<long long>> out;
    if (py::isinstance<py::array>(faces)) {
        const py::array a = py::reinterpret_borrow<py::array>(faces);
        if (a.ndim() != 2) {
            throw OptionError("faces", fmt::format("an array of faces must have shape (F, k), "
                                                   "got {} dimension(s)",
                                                   a.ndim()));
        }
        if (!(a.dtype().kind() == 'i' || a.dtype().kind() == 'u')) {
            throw OptionError("faces", "must hold integer vertex indices, got dtype " +
                                           py::str(a.dtype()).cast<std::string>());
        }
        const auto ints =
            py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
        const long long* d = ints.data();
        const auto rows = static_cast<std::size_t>(ints.shape(0));
        const auto k = static_cast<std::size_t>(ints.shape(1));
        out.resize(rows);
        for (std::size_t f = 0; f < rows; ++f) out[f].assign(d + f * k, d + (f + 1) * k);
        return out;
    }
    for (const py::handle face : faces) {
        std::vector<long long> idx;
        for (const py::handle v : face) {
            if (!py::isinstance<py::int_>(v) &&
                !(py::isinstance<py::array>(v) || py::hasattr(v, "__index__"))) {
                throw OptionError("faces", "must hold integer vertex indices");
            }
            idx.push_back(v.cast<long long>());
        }
        out.push_back(std::move(idx));
    }
    return out;
}

PyScene from_arrays(const py::object& vertices, const py::object& faces,
                    const py::object& obstruction, const py::object& names,
                    const py::object& enclosure_arg, const py::object& name_arg,
                    const py::object& n, const py::object& max_edge) {
    const bool enclosure = arg<bool>(enclosure_arg, "enclosure");
    const std::string name = arg<std::string>(name_arg, "name");
    const auto v = as_doubles(vertices, "vertices", 2);
    if (v.shape(1) != 3) {
        throw OptionError("vertices",
                          fmt::format("must have shape (V, 3), got (V, {})", v.shape(1)));
    }
    const auto nv = static_cast<long long>(v.shape(0));
    const double* vd = v.data();
    const std::vector<std::vector<long long>> polys = face_lists(faces);
    if (polys.empty()) throw OptionError("faces", "no faces");

    std::vector<bool> blocks(polys.size(), false);
    if (!obstruction.is_none()) {
        const auto mask = py::array_t<bool, py::array::forcecast>::ensure(obstruction);
        if (!mask || mask.ndim() != 1 || static_cast<std::size_t>(mask.shape(0)) != polys.size()) {
            throw OptionError("obstruction",
                              fmt::format("must be {} booleans (one per face)", polys.size()));
        }
        for (std::size_t f = 0; f < polys.size(); ++f)
            blocks[f] = mask.at(static_cast<py::ssize_t>(f));
    }
    std::vector<std::string> face_names;
    if (!names.is_none()) {
        face_names = names.cast<std::vector<std::string>>();
        if (face_names.size() != polys.size()) {
            throw OptionError("names", fmt::format("must have {} names (one per face), got {}",
                                                   polys.size(), face_names.size()));
        }
    }

    Scene scene;
    scene.name = name;
    scene.title = name;
    scene.enclosure = enclosure;
    scene.materials.push_back(Material{});
    for (std::size_t f = 0; f < polys.size(); ++f) {
        Surface s;
        s.name = face_names.empty() ? fmt::format("face{}", f) : face_names[f];
        s.obstruction = blocks[f];
        s.where = SourceLocation{name, 0};
        for (const long long idx : polys[f]) {
            if (idx < 0 || idx >= nv) {
                throw OptionError("faces", fmt::format("face {} has vertex index {}, but there are "
                                                       "{} vertices",
                                                       f, idx, nv));
            }
            s.polygon.vertices.emplace_back(vd[3 * idx], vd[3 * idx + 1], vd[3 * idx + 2]);
        }
        try {
            validate_polygon(s.polygon, s.where, fmt::format("face {}", f));
        } catch (const InputError& e) {
            throw OptionError("faces", e.message());
        }
        scene.surfaces.push_back(std::move(s));
    }
    if (scene.obstruction_count() == scene.surfaces.size()) {
        throw OptionError("obstruction",
                          "every face is obstruction-only: the scene has no patches");
    }
    return finish(std::move(scene), n, max_edge);
}

const Scene& get(const PyScene& s) { return *s.scene; }

/// path= of load() and energyplus_zones(): a str or an os.PathLike.
void apply_path(const py::object& v, SceneOptions& o) { o.source = path_arg(v); }

/// The arguments of load(), in order (all may be given by position).
const Keyword<SceneOptions> kLoadKeywords[] = {
    {"path", "Union[str, PathLike[str]]", nullptr,
     "a built-in scene's name (builtin_scenes()) or a file: .obj with its MTL, .vs3 (View3D), an "
     "EnergyPlus .idf / .epJSON model, a Gmsh .msh, or .stl, .ply, .gltf, .glb, .off.",
     apply_path, true},
    {"subdivide", "Optional[int]", "None",
     "n: each quad into n×n patches (triangles into n²); give this or max_edge.", nullptr, true},
    {"max_edge", "Optional[float]", "None",
     "L: split until every patch edge is at most L; give this or subdivide.", nullptr, true},
    {"merge_coplanar", "bool", "False",
     "merge the coplanar, edge-connected triangles of each surface (an STL or glTF mesh, a "
     "Gmsh physical group) back into polygons first, as --merge-coplanar does.",
     [](const py::object& v, SceneOptions& o) {
         o.merge_coplanar = arg<bool>(v, "merge_coplanar");
     },
     true},
    {"zone", "Optional[str]", "None",
     "the zone of an EnergyPlus model whose enclosure is loaded, as --zone does (matched "
     "without regard to case; needed when the model has several: energyplus_zones() lists "
     "them).",
     [](const py::object& v, SceneOptions& o) { o.zone = arg<std::string>(v, "zone"); }, true},
};

const Signature<SceneOptions> kLoad{
    "load", "Scene",
    "Loads a scene, subdivided into patches.\n\nRaises InputError (with .file and .line) for a "
    "bad file or an unknown zone, OptionError for bad options (a zone for a file that is not an "
    "EnergyPlus model).",
    kLoadKeywords};

const Keyword<SceneOptions> kEnergyplusZonesKeywords[] = {
    {"path", "Union[str, PathLike[str]]", nullptr, "an EnergyPlus model: .idf or .epJSON.",
     apply_path, true},
};

const Signature<SceneOptions> kEnergyplusZones{
    "energyplus_zones", "list[str]",
    "The zone names of an EnergyPlus model, in file order: the names load(path, zone=NAME) "
    "takes. Raises InputError for a bad file.",
    kEnergyplusZonesKeywords};

}  // namespace

void bind_scene(py::module_& m) {
    py::class_<PyScene>(m, "Scene", R"doc(
A scene: surfaces (what the file or the arrays drew) and the patches subdivision made of them.

Patches are the rows and columns of the form-factor matrix, in order: surfaces in input order
(obstruction-only surfaces have no patches), the children of a subdivided surface consecutive,
row-major. A Scene is immutable: its per-patch arrays (``areas``, ``normals``, ``centroids``,
``surface_index``) are read-only NumPy views into it, made without copying; ``subdivided()``
returns a new scene.

Make one with :func:`formfactor.load` or :meth:`Scene.from_arrays`.
)doc")
        .def_static("from_arrays", &from_arrays, py::arg("vertices"), py::arg("faces"),
                    py::arg("obstruction") = py::none(), py::arg("names") = py::none(),
                    py::arg("enclosure") = false, py::arg("name") = "arrays",
                    py::arg("subdivide") = py::none(), py::arg("max_edge") = py::none(),
                    R"doc(
A scene from NumPy arrays, as trimesh, meshio or PyVista users hold them.

vertices: (V, 3) floats. faces: an (F, k) integer array of vertex indices (0-based; every face k
vertices), or a list of index sequences (polygons of any sizes). Each face is one surface,
counter-clockwise seen from its front (its normal is the right-hand one); faces are one-sided.
obstruction: optional (F,) booleans: True marks a face that only blocks (no row or column).
names: optional surface names (default ``face0``, ``face1``, ...). enclosure: True when the
faces close a volume (repair may then close the rows). subdivide / max_edge: as in load().

Raises OptionError (option ``vertices``, ``faces``, ...) for bad arrays or a face that is not a
valid planar polygon.
)doc")
        .def(
            "subdivided",
            [](const PyScene& self, const py::object& n, const py::object& max_edge) {
                Scene copy = get(self);
                return finish(std::move(copy), n, max_edge);
            },
            py::arg("subdivide") = py::none(), py::arg("max_edge") = py::none(),
            "A new scene whose surfaces are split again: into subdivide×subdivide children "
            "(quads; triangles into subdivide²), or until every edge is at most max_edge.")
        .def(
            "to_arrays",
            [](const PyScene& self, const py::object& patches_arg) {
                const bool patches = arg<bool>(patches_arg, "patches");
                // (vertices, faces, obstruction, names) that from_arrays() takes back.
                const Scene& s = get(self);
                std::vector<const Polygon*> polys;
                std::vector<bool> blocks;
                std::vector<std::string> names;
                if (patches) {
                    for (std::size_t i = 0; i < s.patches.size(); ++i) {
                        polys.push_back(&s.patches[i].polygon);
                        blocks.push_back(false);
                        const auto surface = static_cast<std::size_t>(s.patches[i].surface);
                        names.push_back(surface < s.surfaces.size()
                                            ? fmt::format("{}#{}", s.surfaces[surface].name, i)
                                            : fmt::format("patch{}", i));
                    }
                }
                for (const Surface& x : s.surfaces) {
                    if (patches && !x.obstruction) continue;
                    if (!x.holes.empty()) {
                        throw OptionError("patches", "surface '" + x.name +
                                                         "' has holes (VS3 subsurfaces), which "
                                                         "arrays cannot hold: use "
                                                         "to_arrays(patches=True)");
                    }
                    polys.push_back(&x.polygon);
                    blocks.push_back(x.obstruction);
                    names.push_back(x.name);
                }
                std::size_t nv = 0;
                for (const Polygon* p : polys) nv += p->size();
                py::array_t<double> v({nv, std::size_t(3)});
                py::list faces;
                py::array_t<bool> mask(static_cast<py::ssize_t>(polys.size()));
                std::size_t k = 0;
                for (std::size_t f = 0; f < polys.size(); ++f) {
                    py::list face;
                    for (const Vec3& x : polys[f]->vertices) {
                        for (int c = 0; c < 3; ++c)
                            v.mutable_at(static_cast<py::ssize_t>(k), c) = x[c];
                        face.append(k++);
                    }
                    faces.append(face);
                    mask.mutable_at(static_cast<py::ssize_t>(f)) = blocks[f];
                }
                return py::make_tuple(v, faces, mask, names);
            },
            py::arg("patches") = false,
            "(vertices, faces, obstruction, names) that Scene.from_arrays() takes back: the "
            "surfaces (patches=False; surfaces with holes cannot be written so) or the patches "
            "and the obstruction-only surfaces (patches=True). Vertices are not shared.")
        .def("__len__", [](const PyScene& s) { return get(s).patches.size(); })
        .def_property_readonly(
            "n_patches", [](const PyScene& s) { return get(s).patches.size(); },
            "Number of patches N (rows and columns of F).")
        .def_property_readonly(
            "n_surfaces", [](const PyScene& s) { return get(s).surfaces.size(); },
            "Number of surfaces, obstruction-only ones included.")
        .def_property_readonly("name", [](const PyScene& s) { return get(s).name; })
        .def_property_readonly("title", [](const PyScene& s) { return get(s).title; })
        .def_property_readonly(
            "enclosure", [](const PyScene& s) { return get(s).enclosure; },
            "True when the scene is known to be a closed enclosure.")
        .def_property_readonly("warnings", [](const PyScene& s) { return get(s).warnings; })
        .def_property_readonly(
            "surface_names",
            [](const PyScene& s) {
                std::vector<std::string> out;
                for (const Surface& x : get(s).surfaces) out.push_back(x.name);
                return out;
            },
            "Names of the surfaces, in input order (obstruction-only ones included).")
        .def_property_readonly(
            "obstruction",
            [](const PyScene& s) {
                py::array_t<bool> out(static_cast<py::ssize_t>(get(s).surfaces.size()));
                for (std::size_t k = 0; k < get(s).surfaces.size(); ++k)
                    out.mutable_at(static_cast<py::ssize_t>(k)) = get(s).surfaces[k].obstruction;
                return out;
            },
            "(S,) booleans: True for obstruction-only surfaces.")
        .def_property_readonly(
            "areas",
            [](const py::object& self) {
                const Scene& s = get(self.cast<const PyScene&>());
                const Patch* p = s.patches.data();
                return readonly_view<double>(&p->area, s.patches.size(), sizeof(Patch), self);
            },
            "(N,) patch areas (a read-only view, no copy).")
        .def_property_readonly(
            "normals",
            [](const py::object& self) {
                const Scene& s = get(self.cast<const PyScene&>());
                const Patch* p = s.patches.data();
                return readonly_view<double>(p->normal.data(), s.patches.size(), sizeof(Patch),
                                             self, 3);
            },
            "(N, 3) unit front normals of the patches (a read-only view, no copy).")
        .def_property_readonly(
            "centroids",
            [](const py::object& self) {
                const Scene& s = get(self.cast<const PyScene&>());
                const Patch* p = s.patches.data();
                return readonly_view<double>(p->centroid.data(), s.patches.size(), sizeof(Patch),
                                             self, 3);
            },
            "(N, 3) patch centroids (a read-only view, no copy).")
        .def_property_readonly(
            "surface_index",
            [](const py::object& self) {
                const Scene& s = get(self.cast<const PyScene&>());
                const Patch* p = s.patches.data();
                return readonly_view<int>(&p->surface, s.patches.size(), sizeof(Patch), self);
            },
            "(N,) index of each patch's surface (into surface_names; a read-only view). "
            "Per-surface values become per-patch ones with values[scene.surface_index].")
        .def(
            "patch_vertices",
            [](const PyScene& s, std::size_t i) {
                if (i >= get(s).patches.size()) throw py::index_error("patch index out of range");
                const Polygon& poly = get(s).patches[i].polygon;
                py::array_t<double> out({poly.size(), std::size_t(3)});
                for (std::size_t k = 0; k < poly.size(); ++k)
                    for (int c = 0; c < 3; ++c)
                        out.mutable_at(static_cast<py::ssize_t>(k), c) = poly[k][c];
                return out;
            },
            py::arg("i"), "The (k, 3) vertices of patch i, counter-clockwise seen from its front.")
        .def_property_readonly(
            "bounds",
            [](const PyScene& s) {
                const Bounds3 b = get(s).bounds();
                return py::make_tuple(py::make_tuple(b.lo.x(), b.lo.y(), b.lo.z()),
                                      py::make_tuple(b.hi.x(), b.hi.y(), b.hi.z()));
            },
            "((xmin, ymin, zmin), (xmax, ymax, zmax)) of every surface.")
        .def(
            "properties",
            [](const PyScene& s) {
                const PatchProperties p = properties_from_scene(get(s));
                const std::size_t n = p.size();
                py::array_t<double> refl({n, std::size_t(3)}), emis({n, std::size_t(3)});
                py::array_t<double> eps(static_cast<py::ssize_t>(n)),
                    temp(static_cast<py::ssize_t>(n));
                for (std::size_t i = 0; i < n; ++i) {
                    const auto k = static_cast<py::ssize_t>(i);
                    for (int c = 0; c < 3; ++c) {
                        refl.mutable_at(k, c) = p.reflectance[i][c];
                        emis.mutable_at(k, c) = p.emission[i][c];
                    }
                    eps.mutable_at(k) = p.emissivity[i];
                    temp.mutable_at(k) = p.temperature[i];
                }
                py::dict d;
                d["reflectance"] = refl;
                d["emission"] = emis;
                d["emissivity"] = eps;
                d["temperature"] = temp;
                return d;
            },
            "The per-patch properties the scene's materials give (new arrays): "
            "{'reflectance': (N, 3), 'emission': (N, 3), 'emissivity': (N,), "
            "'temperature': (N,) in K, NaN where not given}.")
        .def("__repr__", [](const PyScene& s) {
            const Scene& x = get(s);
            return fmt::format(
                "<formfactor.Scene '{}': {} surfaces ({} obstruction-only), {} patches{}>", x.name,
                x.surfaces.size(), x.obstruction_count(), x.patches.size(),
                x.enclosure ? ", enclosure" : "");
        });

    bind_function_with_keywords(
        m, kLoad, [](SceneOptions& o, const std::vector<py::object>& values) {
            if (o.source.empty() && value_of(kLoad, values, "path").is_none())
                throw OptionError("path", "must be a file or a built-in scene's name, got None");
            Scene scene;
            {
                py::gil_scoped_release nogil;
                scene = load_scene(o);
                if (o.merge_coplanar) merge_coplanar(scene);
            }
            return finish(std::move(scene), value_of(kLoad, values, "subdivide"),
                          value_of(kLoad, values, "max_edge"));
        });
    bind_function_with_keywords(m, kEnergyplusZones,
                                [](const SceneOptions& o, const std::vector<py::object>&) {
                                    py::gil_scoped_release nogil;
                                    return energyplus_zones(o.source);
                                });
    m.def("builtin_scenes", &builtin_scene_names, "Names of the built-in scenes.");
}

}  // namespace formfactor::python
