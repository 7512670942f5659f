#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "formfactor/core/error.h"
#include "formfactor/output/render.h"
#include "output/render_internal.h"

namespace formfactor {

namespace {

std::string extension_of(const std::string& path) {
    const auto dot = path.find_last_of('.');
    const auto slash = path.find_last_of('/');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string e = path.substr(dot);
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
    return e;
}

template <class T>
void put(std::string& out, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // little-endian hosts only (x86-64, aarch64)
    out.append(b, sizeof(T));
}

std::string base64(const std::string& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        const unsigned v = (static_cast<unsigned char>(in[i]) << 16) |
                           (static_cast<unsigned char>(in[i + 1]) << 8) |
                           static_cast<unsigned char>(in[i + 2]);
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += t[(v >> 6) & 63];
        out += t[v & 63];
    }
    if (i + 1 == in.size()) {
        const unsigned v = static_cast<unsigned char>(in[i]) << 16;
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += "==";
    } else if (i + 2 == in.size()) {
        const unsigned v = (static_cast<unsigned char>(in[i]) << 16) |
                           (static_cast<unsigned char>(in[i + 1]) << 8);
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += t[(v >> 6) & 63];
        out += '=';
    }
    return out;
}

std::string ply(const detail::ShadedMesh& m, const std::vector<Rgb>& colour, bool binary) {
    std::string out = fmt::format(
        "ply\nformat {} 1.0\ncomment formfactor radiosity, sRGB vertex colours\n"
        "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        binary ? "binary_little_endian" : "ascii", m.positions.size(), m.triangles.size());
    for (std::size_t v = 0; v < m.positions.size(); ++v) {
        const Vec3& p = m.positions[v];
        std::uint8_t c[3];
        for (int k = 0; k < 3; ++k) c[k] = detail::linear_to_srgb8(colour[v][k]);
        if (binary) {
            for (int k = 0; k < 3; ++k) put(out, static_cast<float>(p[k]));
            out.append(reinterpret_cast<const char*>(c), 3);
        } else {
            out +=
                fmt::format("{} {} {} {} {} {}\n", static_cast<float>(p.x()),
                            static_cast<float>(p.y()), static_cast<float>(p.z()), c[0], c[1], c[2]);
        }
    }
    for (const auto& t : m.triangles) {
        if (binary) {
            put(out, static_cast<std::uint8_t>(3));
            for (int k : t) put(out, static_cast<std::int32_t>(k));
        } else {
            out += fmt::format("3 {} {} {}\n", t[0], t[1], t[2]);
        }
    }
    return out;
}

// glTF 2.0: positions and linear COLOR_0 as float VEC3, uint32 indices, one unlit material.
std::string gltf(const detail::ShadedMesh& m, const std::vector<Rgb>& colour, bool glb) {
    std::string bin;
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (const Vec3& p : m.positions) {
        for (int k = 0; k < 3; ++k) put(bin, static_cast<float>(p[k]));
        lo = lo.cwiseMin(p.cast<float>().cast<double>());
        hi = hi.cwiseMax(p.cast<float>().cast<double>());
    }
    const std::size_t pos_bytes = bin.size();
    for (const Rgb& c : colour)
        for (int k = 0; k < 3; ++k)
            put(bin, static_cast<float>(std::isfinite(c[k]) ? std::clamp(c[k], 0.0, 1.0) : 0.0));
    const std::size_t col_bytes = bin.size() - pos_bytes;
    for (const auto& t : m.triangles)
        for (int k : t) put(bin, static_cast<std::uint32_t>(k));
    const std::size_t idx_bytes = bin.size() - pos_bytes - col_bytes;
    const std::size_t nv = m.positions.size();
    if (m.positions.empty()) lo = hi = Vec3::Zero();

    nlohmann::json j;
    j["asset"] = {{"version", "2.0"}, {"generator", "formfactor " FF_VERSION}};
    j["extensionsUsed"] = {"KHR_materials_unlit"};
    j["scene"] = 0;
    j["scenes"] = {{{"nodes", {0}}}};
    j["nodes"] = {{{"mesh", 0}, {"name", "radiosity"}}};
    j["materials"] = {{{"name", "radiosity"},
                       {"pbrMetallicRoughness",
                        {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}},
                         {"metallicFactor", 0.0},
                         {"roughnessFactor", 1.0}}},
                       {"extensions", {{"KHR_materials_unlit", nlohmann::json::object()}}}}};
    j["meshes"] = {{{"primitives",
                     {{{"attributes", {{"POSITION", 0}, {"COLOR_0", 1}}},
                       {"indices", 2},
                       {"material", 0},
                       {"mode", 4}}}}}};
    nlohmann::json buffer = {{"byteLength", bin.size()}};
    if (!glb) buffer["uri"] = "data:application/octet-stream;base64," + base64(bin);
    // An array of one: `= {buffer}` would copy the object under clang (CWG 1467).
    j["buffers"] = nlohmann::json::array({buffer});
    j["bufferViews"] = {
        {{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos_bytes}, {"target", 34962}},
        {{"buffer", 0}, {"byteOffset", pos_bytes}, {"byteLength", col_bytes}, {"target", 34962}},
        {{"buffer", 0},
         {"byteOffset", pos_bytes + col_bytes},
         {"byteLength", idx_bytes},
         {"target", 34963}}};
    j["accessors"] = {{{"bufferView", 0},
                       {"componentType", 5126},
                       {"count", nv},
                       {"type", "VEC3"},
                       {"min", {lo.x(), lo.y(), lo.z()}},
                       {"max", {hi.x(), hi.y(), hi.z()}}},
                      {{"bufferView", 1}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"}},
                      {{"bufferView", 2},
                       {"componentType", 5125},
                       {"count", 3 * m.triangles.size()},
                       {"type", "SCALAR"}}};
    std::string text = j.dump();
    if (!glb) return text + "\n";
    while (text.size() % 4) text += ' ';
    while (bin.size() % 4) bin += '\0';
    std::string out;
    put(out, static_cast<std::uint32_t>(0x46546C67));  // "glTF"
    put(out, static_cast<std::uint32_t>(2));
    put(out, static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
    put(out, static_cast<std::uint32_t>(text.size()));
    put(out, static_cast<std::uint32_t>(0x4E4F534A));  // "JSON"
    out += text;
    put(out, static_cast<std::uint32_t>(bin.size()));
    put(out, static_cast<std::uint32_t>(0x004E4942));  // "BIN\0"
    out += bin;
    return out;
}

}  // namespace

bool is_mesh_path(const std::string& path) {
    const std::string ext = extension_of(path);
    return ext == ".ply" || ext == ".gltf" || ext == ".glb";
}

void write_mesh(const std::string& path, const Scene& scene, const std::vector<Rgb>& radiance,
                const ExportOptions& options) {
    detail::write_bytes_atomically(path, encode_mesh(path, scene, radiance, options));
}

std::string encode_mesh(const std::string& path, const Scene& scene,
                        const std::vector<Rgb>& radiance, const ExportOptions& options) {
    const std::string ext = extension_of(path);
    if (!is_mesh_path(path))
        throw OptionError("output",
                          "unknown 3D export extension '" + ext + "' (use .ply, .gltf or .glb)");
    if (radiance.size() != scene.patches.size())
        throw Error(
            fmt::format("export: {} values for {} patches", radiance.size(), scene.patches.size()));
    double exposure = options.exposure;
    if (!(exposure > 0.0)) {
        const double q = detail::patch_luminance_quantile(scene, radiance, options.emitters, 0.99);
        exposure = q > 0.0 ? 0.9 / q : 1.0;
    }
    const detail::ShadedMesh mesh = detail::shaded_mesh(scene, radiance, options.flat);
    std::vector<Rgb> colour(mesh.values.size());
    for (std::size_t v = 0; v < colour.size(); ++v)
        colour[v] = mesh.values[v].allFinite()
                        ? Rgb((exposure * mesh.values[v]).cwiseMax(0.0).cwiseMin(1.0))
                        : Rgb(Rgb::Constant(0.5));
    return ext == ".ply" ? ply(mesh, colour, options.binary) : gltf(mesh, colour, ext == ".glb");
}

std::string encode_false_colour_mesh(const std::string& path, const Scene& scene,
                                     const FalseColourField& field, bool flat, double* lo,
                                     double* hi) {
    double low = INFINITY, high = -INFINITY;
    for (double v : field.values)
        if (std::isfinite(v)) low = std::min(low, v), high = std::max(high, v);
    std::vector<Rgb> colours;
    colours.reserve(field.values.size());
    for (double v : field.values) {
        const Rgb c = std::isfinite(v)
                          ? colormap_inferno(high > low ? (v - low) / (high - low) : 0.0)
                          : Rgb::Constant(0.5);
        colours.emplace_back(detail::srgb_to_linear(c[0]), detail::srgb_to_linear(c[1]),
                             detail::srgb_to_linear(c[2]));
    }
    ExportOptions eo;
    eo.flat = flat;
    eo.exposure = 1.0;
    if (lo) *lo = low;
    if (hi) *hi = high;
    return encode_mesh(path, scene, colours, eo);
}

}  // namespace formfactor
