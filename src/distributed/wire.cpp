// The ranks' messages as flat bytes (wire.h).

#include "wire.h"

namespace formfactor::distributed {

namespace {

void put_vec3(WireWriter& w, const Vec3& v) {
    for (int k = 0; k < 3; ++k) w.put(v[k]);
}

Vec3 get_vec3(WireReader& r) {
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = r.get<double>();
    return v;
}

void put_rgb(WireWriter& w, const Rgb& c) {
    for (int k = 0; k < 3; ++k) w.put(c[k]);
}

Rgb get_rgb(WireReader& r) {
    Rgb c;
    for (int k = 0; k < 3; ++k) c[k] = r.get<double>();
    return c;
}

void put_polygon(WireWriter& w, const Polygon& p) {
    w.put<std::uint64_t>(p.vertices.size());
    for (const Vec3& v : p.vertices) put_vec3(w, v);
}

Polygon get_polygon(WireReader& r) {
    Polygon p;
    const auto count = r.get<std::uint64_t>();
    for (std::uint64_t k = 0; k < count; ++k) p.vertices.push_back(get_vec3(r));
    return p;
}

void put_fields(WireWriter& w, const Fields& f) {
    w.put(static_cast<std::int32_t>(f.kind()));
    switch (f.kind()) {
        case Fields::Kind::null:
            break;
        case Fields::Kind::boolean:
            w.put<std::uint8_t>(f.boolean());
            break;
        case Fields::Kind::integer:
            w.put(f.integer());
            break;
        case Fields::Kind::unsigned_integer:
            w.put(f.unsigned_integer());
            break;
        case Fields::Kind::real:
            w.put(f.real());
            break;
        case Fields::Kind::text:
            w.put_string(f.text());
            break;
        case Fields::Kind::reals:
            w.put_vector(f.reals());
            break;
        case Fields::Kind::object:
            w.put<std::uint64_t>(f.keys().size());
            for (std::size_t k = 0; k < f.keys().size(); ++k) {
                w.put_string(f.keys()[k]);
                put_fields(w, f.values()[k]);
            }
            break;
    }
}

Fields get_fields(WireReader& r) {
    Fields f;
    switch (static_cast<Fields::Kind>(r.get<std::int32_t>())) {
        case Fields::Kind::null:
            break;
        case Fields::Kind::boolean:
            f = r.get<std::uint8_t>() != 0;
            break;
        case Fields::Kind::integer:
            f = r.get<std::int64_t>();
            break;
        case Fields::Kind::unsigned_integer:
            f = r.get<std::uint64_t>();
            break;
        case Fields::Kind::real:
            f = r.get<double>();
            break;
        case Fields::Kind::text:
            f = r.get_string();
            break;
        case Fields::Kind::reals:
            f = r.get_vector<double>();
            break;
        case Fields::Kind::object: {
            f = Fields::object();
            const auto count = r.get<std::uint64_t>();
            for (std::uint64_t k = 0; k < count; ++k) {
                const std::string key = r.get_string();
                f[key] = get_fields(r);
            }
            break;
        }
        default:
            throw Error("distributed: a report field of an unknown kind");
    }
    return f;
}

template <class T>
void put_optional(WireWriter& w, const std::optional<T>& v) {
    w.put<std::uint8_t>(v.has_value());
    if (v) w.put(*v);
}

template <class T>
std::optional<T> get_optional(WireReader& r) {
    if (r.get<std::uint8_t>() == 0) return std::nullopt;
    return r.get<T>();
}

}  // namespace

void put_scene(WireWriter& w, const Scene& scene) {
    w.put_string(scene.name);
    w.put_string(scene.title);
    w.put<std::uint64_t>(scene.materials.size());
    for (const Material& m : scene.materials) {
        w.put_string(m.name);
        put_rgb(w, m.reflectance);
        put_rgb(w, m.emission);
        w.put(m.emissivity);
        w.put(m.temperature);
    }
    w.put<std::uint64_t>(scene.surfaces.size());
    for (const Surface& s : scene.surfaces) {
        w.put_string(s.name);
        put_polygon(w, s.polygon);
        w.put(s.material);
        w.put<std::uint8_t>(s.obstruction);
        w.put(s.base);
        w.put(s.combine);
        w.put_string(s.where.file);
        w.put(s.where.line);
        w.put<std::uint64_t>(s.holes.size());
        for (const Polygon& h : s.holes) put_polygon(w, h);
    }
    w.put<std::uint64_t>(scene.patches.size());
    for (const Patch& p : scene.patches) {
        put_polygon(w, p.polygon);
        w.put(p.surface);
        w.put(p.area);
        put_vec3(w, p.normal);
        put_vec3(w, p.centroid);
    }
    w.put<std::uint64_t>(scene.warnings.size());
    for (const std::string& s : scene.warnings) w.put_string(s);
    w.put<std::uint8_t>(scene.camera.has_value());
    if (scene.camera) {
        put_vec3(w, scene.camera->eye);
        put_vec3(w, scene.camera->target);
        put_vec3(w, scene.camera->up);
        w.put(scene.camera->fov_degrees);
    }
    put_optional(w, scene.vs3_control);
    w.put<std::uint8_t>(scene.enclosure);
}

Scene get_scene(WireReader& r) {
    Scene scene;
    scene.name = r.get_string();
    scene.title = r.get_string();
    const auto materials = r.get<std::uint64_t>();
    for (std::uint64_t k = 0; k < materials; ++k) {
        Material m;
        m.name = r.get_string();
        m.reflectance = get_rgb(r);
        m.emission = get_rgb(r);
        m.emissivity = r.get<double>();
        m.temperature = r.get<double>();
        scene.materials.push_back(std::move(m));
    }
    const auto surfaces = r.get<std::uint64_t>();
    scene.surfaces.reserve(surfaces);
    for (std::uint64_t k = 0; k < surfaces; ++k) {
        Surface s;
        s.name = r.get_string();
        s.polygon = get_polygon(r);
        s.material = r.get<int>();
        s.obstruction = r.get<std::uint8_t>() != 0;
        s.base = r.get<int>();
        s.combine = r.get<int>();
        s.where.file = r.get_string();
        s.where.line = r.get<int>();
        const auto holes = r.get<std::uint64_t>();
        for (std::uint64_t h = 0; h < holes; ++h) s.holes.push_back(get_polygon(r));
        scene.surfaces.push_back(std::move(s));
    }
    const auto patches = r.get<std::uint64_t>();
    scene.patches.reserve(patches);
    for (std::uint64_t k = 0; k < patches; ++k) {
        Patch p;
        p.polygon = get_polygon(r);
        p.surface = r.get<int>();
        p.area = r.get<double>();
        p.normal = get_vec3(r);
        p.centroid = get_vec3(r);
        scene.patches.push_back(std::move(p));
    }
    const auto warnings = r.get<std::uint64_t>();
    for (std::uint64_t k = 0; k < warnings; ++k) scene.warnings.push_back(r.get_string());
    if (r.get<std::uint8_t>() != 0) {
        Camera c;
        c.eye = get_vec3(r);
        c.target = get_vec3(r);
        c.up = get_vec3(r);
        c.fov_degrees = r.get<double>();
        scene.camera = c;
    }
    scene.vs3_control = get_optional<Vs3Control>(r);
    scene.enclosure = r.get<std::uint8_t>() != 0;
    return scene;
}

void put_report(WireWriter& w, const MethodReport& report) {
    w.put(report.method);
    put_optional(w, report.error_bound_per_entry);
    put_optional(w, report.pairs);
    put_optional(w, report.rays_cast);
    put_optional(w, report.seconds);
    put_fields(w, report.details);
}

MethodReport get_report(WireReader& r) {
    MethodReport report;
    report.method = r.get<MethodKind>();
    report.error_bound_per_entry = get_optional<double>(r);
    report.pairs = get_optional<PairClasses>(r);
    report.rays_cast = get_optional<std::uint64_t>(r);
    report.seconds = get_optional<double>(r);
    report.details = get_fields(r);
    return report;
}

void put_sparse_rows(WireWriter& w, const SparseRows& rows) {
    w.put<std::uint64_t>(rows.first_row);
    w.put<std::uint64_t>(rows.size());
    w.put<std::uint8_t>(rows.has_standard_errors());
    for (std::size_t r = 0; r < rows.size(); ++r) {
        w.put_vector(rows.indices[r]);
        w.put_vector(rows.values[r]);
        if (rows.has_standard_errors()) w.put_vector(rows.standard_error[r]);
    }
}

SparseRows get_sparse_rows(WireReader& r) {
    SparseRows rows;
    const auto first = r.get<std::uint64_t>();
    const auto count = r.get<std::uint64_t>();
    const bool se = r.get<std::uint8_t>() != 0;
    rows.reset(first, count, se);
    for (std::size_t k = 0; k < count; ++k) {
        rows.indices[k] = r.get_vector<std::int32_t>();
        rows.values[k] = r.get_vector<double>();
        if (se) rows.standard_error[k] = r.get_vector<double>();
    }
    return rows;
}

SparseRows nonzero_rows(const FormFactors& block) {
    SparseRows rows;
    const std::size_t m = block.size(), n = static_cast<std::size_t>(block.F.cols());
    const bool se = block.standard_error.has_value();
    rows.reset(block.first_row, m, se);
    for (std::size_t r = 0; r < m; ++r) {
        const double* row = block.F.data() + r * n;
        const double* err = se ? block.standard_error->data() + r * n : nullptr;
        for (std::size_t j = 0; j < n; ++j) {
            if (row[j] == 0.0) continue;  // NaN is kept (it compares unequal)
            rows.indices[r].push_back(static_cast<std::int32_t>(j));
            rows.values[r].push_back(row[j]);
            if (se) rows.standard_error[r].push_back(err[j]);
        }
    }
    return rows;
}

}  // namespace formfactor::distributed
