#pragma once
// Writers of STL, PLY, OFF, OBJ and glTF 2.0 for the tests, made from the formats'
// specifications (independent of the library and of Open Asset Import, which reads them): the
// files the mesh reader is tested on.

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "formfactor/core/types.h"

namespace formfactor::testing {

/// A mesh: vertices and faces (vertex indices, counter-clockwise seen from the front).
struct TestMesh {
    std::string name;
    std::vector<Vec3> vertices;
    std::vector<std::vector<int>> faces;
};

/// The closed unit box [0, 1]³, six quads facing inward.
inline TestMesh unit_box_quads(const std::string& name = "box") {
    TestMesh m;
    m.name = name;
    for (int z = 0; z < 2; ++z) {
        m.vertices.emplace_back(0, 0, z);
        m.vertices.emplace_back(1, 0, z);
        m.vertices.emplace_back(1, 1, z);
        m.vertices.emplace_back(0, 1, z);
    }
    m.faces = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1}, {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
    return m;
}

/// The same mesh with every polygon fanned into triangles (a, b, c), (a, c, d), ...
inline TestMesh triangulated(const TestMesh& q) {
    TestMesh t = q;
    t.faces.clear();
    for (const auto& f : q.faces)
        for (std::size_t k = 1; k + 1 < f.size(); ++k) t.faces.push_back({f[0], f[k], f[k + 1]});
    return t;
}

inline std::string number(double x) {
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", x);
    return b;
}

template <class T>
void put(std::string& out, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    out.append(b, sizeof(T));
}

/// ASCII STL (`solid NAME` ... `endsolid NAME`); the facet normals from the vertex order.
inline std::string stl_ascii(const TestMesh& m) {
    std::string s = "solid " + m.name + "\n";
    for (const auto& f : m.faces) {
        const Vec3 a = m.vertices[f[0]], b = m.vertices[f[1]], c = m.vertices[f[2]];
        const Vec3 n = (b - a).cross(c - a).normalized();
        s += "  facet normal " + number(n.x()) + " " + number(n.y()) + " " + number(n.z()) +
             "\n    outer loop\n";
        for (int k = 0; k < 3; ++k) {
            const Vec3& v = m.vertices[f[k]];
            s += "      vertex " + number(v.x()) + " " + number(v.y()) + " " + number(v.z()) + "\n";
        }
        s += "    endloop\n  endfacet\n";
    }
    return s + "endsolid " + m.name + "\n";
}

/// Binary STL: an 80-byte header (not beginning with "solid"), the triangle count, and 50 bytes
/// per triangle (normal, three vertices as little-endian floats, a 16-bit attribute).
inline std::string stl_binary(const TestMesh& m) {
    std::string s(80, ' ');
    std::memcpy(s.data(), "binary STL written by the formfactor tests", 42);
    put<std::uint32_t>(s, static_cast<std::uint32_t>(m.faces.size()));
    for (const auto& f : m.faces) {
        const Vec3 a = m.vertices[f[0]], b = m.vertices[f[1]], c = m.vertices[f[2]];
        const Vec3 n = (b - a).cross(c - a).normalized();
        for (int k = 0; k < 3; ++k) put<float>(s, static_cast<float>(n[k]));
        for (int v = 0; v < 3; ++v)
            for (int k = 0; k < 3; ++k) put<float>(s, static_cast<float>(m.vertices[f[v]][k]));
        put<std::uint16_t>(s, 0);
    }
    return s;
}

/// PLY 1.0, ascii or binary_little_endian: vertex x y z (float), face vertex_indices (uchar
/// count, int indices).
inline std::string ply(const TestMesh& m, bool binary) {
    std::string s = std::string("ply\nformat ") + (binary ? "binary_little_endian" : "ascii") +
                    " 1.0\ncomment written by the formfactor tests\nelement vertex " +
                    std::to_string(m.vertices.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                    std::to_string(m.faces.size()) +
                    "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const Vec3& v : m.vertices) {
        if (binary)
            for (int k = 0; k < 3; ++k) put<float>(s, static_cast<float>(v[k]));
        else
            s += number(v.x()) + " " + number(v.y()) + " " + number(v.z()) + "\n";
    }
    for (const auto& f : m.faces) {
        if (binary) {
            put<std::uint8_t>(s, static_cast<std::uint8_t>(f.size()));
            for (int i : f) put<std::int32_t>(s, i);
        } else {
            s += std::to_string(f.size());
            for (int i : f) s += " " + std::to_string(i);
            s += "\n";
        }
    }
    return s;
}

/// OFF: `OFF`, counts, vertices, faces `n i0 i1 ...`.
inline std::string off(const TestMesh& m) {
    std::string s =
        "OFF\n" + std::to_string(m.vertices.size()) + " " + std::to_string(m.faces.size()) + " 0\n";
    for (const Vec3& v : m.vertices)
        s += number(v.x()) + " " + number(v.y()) + " " + number(v.z()) + "\n";
    for (const auto& f : m.faces) {
        s += std::to_string(f.size());
        for (int i : f) s += " " + std::to_string(i);
        s += "\n";
    }
    return s;
}

/// Wavefront OBJ: one group per mesh (`g NAME`), every face.
inline std::string obj(const std::vector<TestMesh>& meshes) {
    std::string s;
    int base = 1;
    for (const TestMesh& m : meshes) {
        for (const Vec3& v : m.vertices)
            s += "v " + number(v.x()) + " " + number(v.y()) + " " + number(v.z()) + "\n";
        s += "g " + m.name + "\n";
        for (const auto& f : m.faces) {
            s += "f";
            for (int i : f) s += " " + std::to_string(base + i);
            s += "\n";
        }
        base += static_cast<int>(m.vertices.size());
    }
    return s;
}

inline std::string base64(const std::string& in) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    std::size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        const unsigned n = (static_cast<unsigned char>(in[i]) << 16) |
                           (static_cast<unsigned char>(in[i + 1]) << 8) |
                           static_cast<unsigned char>(in[i + 2]);
        for (int s = 18; s >= 0; s -= 6) out += k[(n >> s) & 63];
    }
    if (i + 1 == in.size()) {
        const unsigned n = static_cast<unsigned char>(in[i]) << 16;
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += "==";
    } else if (i + 2 == in.size()) {
        const unsigned n = (static_cast<unsigned char>(in[i]) << 16) |
                           (static_cast<unsigned char>(in[i + 1]) << 8);
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += k[(n >> 6) & 63];
        out += '=';
    }
    return out;
}

/// A glTF node: a mesh, a translation and its material (base colour, emissive).
struct GltfPart {
    TestMesh mesh;  ///< triangles only
    Vec3 translation = Vec3::Zero();
    std::array<double, 3> base_color{1, 1, 1};
    std::array<double, 3> emissive{0, 0, 0};
};

/// glTF 2.0 (glTF 2.0 specification): one node, mesh and material per part; POSITION float
/// VEC3 and unsigned-int indices in one buffer. `glb`: the binary container (12-byte header,
/// a JSON chunk and a BIN chunk, each 4-byte aligned); otherwise a .gltf whose buffer is a
/// base64 data URI.
inline std::string gltf(const std::vector<GltfPart>& parts, bool glb) {
    std::string bin, views, accessors, meshes, nodes, materials, scene_nodes;
    for (std::size_t p = 0; p < parts.size(); ++p) {
        const TestMesh& m = parts[p].mesh;
        const std::string sep = p ? "," : "";
        const std::size_t pos_offset = bin.size();
        Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
        for (const Vec3& v : m.vertices) {
            for (int k = 0; k < 3; ++k) put<float>(bin, static_cast<float>(v[k]));
            lo = lo.cwiseMin(v);
            hi = hi.cwiseMax(v);
        }
        const std::size_t idx_offset = bin.size();
        for (const auto& f : m.faces)
            for (int i : f) put<std::uint32_t>(bin, static_cast<std::uint32_t>(i));
        const std::size_t a = 2 * p;
        views += sep + "{\"buffer\":0,\"byteOffset\":" + std::to_string(pos_offset) +
                 ",\"byteLength\":" + std::to_string(idx_offset - pos_offset) +
                 ",\"target\":34962},{\"buffer\":0,\"byteOffset\":" + std::to_string(idx_offset) +
                 ",\"byteLength\":" + std::to_string(bin.size() - idx_offset) +
                 ",\"target\":34963}";
        accessors += sep + "{\"bufferView\":" + std::to_string(a) +
                     ",\"componentType\":5126,\"count\":" + std::to_string(m.vertices.size()) +
                     ",\"type\":\"VEC3\",\"min\":[" + number(lo.x()) + "," + number(lo.y()) + "," +
                     number(lo.z()) + "],\"max\":[" + number(hi.x()) + "," + number(hi.y()) + "," +
                     number(hi.z()) + "]},{\"bufferView\":" + std::to_string(a + 1) +
                     ",\"componentType\":5125,\"count\":" + std::to_string(3 * m.faces.size()) +
                     ",\"type\":\"SCALAR\"}";
        meshes += sep + "{\"name\":\"" + m.name + "-mesh\",\"primitives\":[{\"attributes\":{" +
                  "\"POSITION\":" + std::to_string(a) + "},\"indices\":" + std::to_string(a + 1) +
                  ",\"material\":" + std::to_string(p) + ",\"mode\":4}]}";
        const Vec3& t = parts[p].translation;
        nodes += sep + "{\"name\":\"" + m.name + "\",\"mesh\":" + std::to_string(p) +
                 ",\"translation\":[" + number(t.x()) + "," + number(t.y()) + "," + number(t.z()) +
                 "]}";
        const auto& c = parts[p].base_color;
        const auto& e = parts[p].emissive;
        materials += sep + "{\"name\":\"" + m.name + "-material\",\"pbrMetallicRoughness\":{" +
                     "\"baseColorFactor\":[" + number(c[0]) + "," + number(c[1]) + "," +
                     number(c[2]) + ",1]},\"emissiveFactor\":[" + number(e[0]) + "," +
                     number(e[1]) + "," + number(e[2]) + "]}";
        scene_nodes += sep + std::to_string(p);
    }
    while (bin.size() % 4) bin += '\0';
    std::string json =
        "{\"asset\":{\"version\":\"2.0\",\"generator\":\"formfactor tests\"},"
        "\"scene\":0,\"scenes\":[{\"nodes\":[" +
        scene_nodes + "]}],\"nodes\":[" + nodes + "],\"meshes\":[" + meshes + "],\"materials\":[" +
        materials + "],\"accessors\":[" + accessors + "],\"bufferViews\":[" + views +
        "],\"buffers\":[{\"byteLength\":" + std::to_string(bin.size()) +
        (glb ? std::string()
             : ",\"uri\":\"data:application/octet-stream;base64," + base64(bin) + "\"") +
        "}]}";
    if (!glb) return json;
    while (json.size() % 4) json += ' ';
    std::string out = "glTF";
    put<std::uint32_t>(out, 2);
    put<std::uint32_t>(out, static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
    put<std::uint32_t>(out, static_cast<std::uint32_t>(json.size()));
    put<std::uint32_t>(out, 0x4E4F534Au);  // "JSON"
    out += json;
    put<std::uint32_t>(out, static_cast<std::uint32_t>(bin.size()));
    put<std::uint32_t>(out, 0x004E4942u);  // "BIN"
    out += bin;
    return out;
}

}  // namespace formfactor::testing
