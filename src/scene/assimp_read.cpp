// STL (ASCII and binary), PLY, glTF 2.0 (.gltf / .glb) and OFF through Open Asset Import
// (Debian's libassimp-dev): assimp parses, this file checks what it returns against our error
// contract (finite coordinates, indices in range, no degenerate or non-planar face) and makes
// the surfaces. PLY files are checked by our own reading of the format first (ply_check.h):
// assimp's PLY reader loops forever on some damaged headers, and no file reaches it under
// another extension. Only this file includes assimp.

#include <assimp/BaseImporter.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <cctype>
#include <exception>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/scene/mesh_io.h"
#include "scene/glb_check.h"
#include "scene/off_check.h"
#include "scene/ply_check.h"
#include "scene/text.h"

namespace formfactor {

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

// A name the file gave, or "" for none or one of assimp's own placeholders ("<STL_ASCII>").
std::string given_name(const aiString& s) {
    const std::string n = detail::trim(std::string(s.C_Str(), s.length));
    if (n.empty() || n.front() == '<' || n == "$dummy_root") return "";
    return n;
}

bool is_obstruction_name(const std::string& name) {
    return lower(name).rfind("obstruction", 0) == 0;
}

// Keeps the first error assimp logs: its readers log some bad input (an OFF face index out of
// range) as an error and go on with a guess, which we refuse.
class FirstError : public Assimp::LogStream {
  public:
    explicit FirstError(std::string* out) : out_(out) {}
    void write(const char* message) override {
        if (!out_->empty()) return;
        std::string m = detail::trim(message);
        const std::size_t colon = m.find(": ");
        if (m.rfind("Error", 0) == 0 && colon != std::string::npos) m = m.substr(colon + 2);
        *out_ = m;
    }

  private:
    std::string* out_;
};

// assimp's logger is one per process: imports are taken one at a time.
std::mutex& import_mutex() {
    static std::mutex m;
    return m;
}

class AssimpReader {
  public:
    explicit AssimpReader(std::string path) : path_(std::move(path)) {}

    Scene read() {
        if (!std::filesystem::is_regular_file(path_))
            throw InputError(path_, 0, "cannot open file");
        const std::string ext = lower(std::filesystem::path(path_).extension().string());
        gltf_ = ext == ".gltf" || ext == ".glb";
        if (ext == ".ply") detail::check_ply(path_);
        if (ext == ".off") detail::check_off(path_);
        if (gltf_) detail::check_glb(path_);
        std::lock_guard<std::mutex> lock(import_mutex());
        std::string logged;
        Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
        Assimp::DefaultLogger::get()->attachStream(new FirstError(&logged), Assimp::Logger::Err);
        struct KillLogger {
            ~KillLogger() { Assimp::DefaultLogger::kill(); }
        } kill_logger;
        Assimp::Importer importer;
        require_a_reader_by_content(importer, ext);
        // A reader that logged an error went on with a guess, which may leave its data
        // inconsistent (an OFF whose faces were all dropped): it is refused before assimp's own
        // check of its data structure walks that data.
        auto step = [&](auto&& call) {
            const aiScene* result = nullptr;
            try {
                result = call();
            } catch (const std::exception& e) {
                throw InputError(path_, 0, std::string("cannot read the mesh: ") + e.what());
            }
            if (result == nullptr)
                throw InputError(path_, 0,
                                 "cannot read the mesh (Open Asset Import: " +
                                     detail::trim(importer.GetErrorString()) + ")");
            if (!logged.empty())
                throw InputError(path_, 0, "bad mesh (Open Asset Import: " + logged + ")");
            return result;
        };
        // No post-processing that changes the geometry: faces as the file has them (PLY and OFF
        // polygons stay polygons).
        step([&] { return importer.ReadFile(path_, 0); });
        const aiScene* sc =
            step([&] { return importer.ApplyPostProcessing(aiProcess_ValidateDataStructure); });
        if (sc->mFlags & AI_SCENE_FLAGS_INCOMPLETE)
            throw InputError(path_, 0, "the file holds no complete mesh");
        scene_.name = path_;
        scene_.materials.push_back(Material{});
        if (sc->mRootNode == nullptr) throw InputError(path_, 0, "the file holds no scene");
        walk(*sc, *sc->mRootNode, Eigen::Matrix4d::Identity(), 0);
        return std::move(scene_);
    }

  private:
    [[noreturn]] void fail(const std::string& msg) const { throw InputError(path_, 0, msg); }

    // Where several of assimp's readers claim the extension (.gltf and .glb: glTF 1 and 2), it
    // asks each whether it recognises the content, and when none does it tries every reader it
    // has; its PLY reader, given a damaged PLY named .gltf, then loops forever. Refused here
    // instead, as assimp's own test of the content decides.
    void require_a_reader_by_content(Assimp::Importer& importer, const std::string& ext) const {
        int claimants = 0;
        bool recognised = false;
        for (std::size_t k = 0; k < importer.GetImporterCount(); ++k) {
            Assimp::BaseImporter* reader = importer.GetImporter(k);
            std::set<std::string> extensions;
            reader->GetExtensionList(extensions);
            if (ext.size() < 2 || extensions.count(ext.substr(1)) == 0) continue;
            ++claimants;
            recognised = recognised || reader->CanRead(path_, importer.GetIOHandler(), true);
        }
        if (claimants > 1 && !recognised)
            fail("not a " + ext +
                 " file that Open Asset Import recognises (damaged, or another format under "
                 "this extension?)");
    }

    // Node transformations are composed in double (assimp stores them in float).
    void walk(const aiScene& sc, const aiNode& node, const Eigen::Matrix4d& parent, int depth) {
        if (depth > 256) fail("the node hierarchy is deeper than 256");
        Eigen::Matrix4d local;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c)
                local(r, c) = static_cast<double>(node.mTransformation[r][c]);
        if (!local.allFinite())
            fail("node '" + std::string(node.mName.C_Str()) +
                 "' has a transformation that is not finite");
        const Eigen::Matrix4d m = parent * local;
        for (unsigned k = 0; k < node.mNumMeshes; ++k) {
            if (node.mMeshes == nullptr || node.mMeshes[k] >= sc.mNumMeshes)
                fail("node '" + std::string(node.mName.C_Str()) + "' refers to a missing mesh");
            const aiMesh& mesh = *sc.mMeshes[node.mMeshes[k]];
            std::string name = given_name(node.mName);
            if (name.empty()) name = given_name(mesh.mName);
            if (name.empty()) name = std::filesystem::path(path_).stem().string();
            if (node.mNumMeshes > 1) name += "." + std::to_string(k + 1);
            add_mesh(sc, mesh, m, unique(name));
        }
        for (unsigned c = 0; c < node.mNumChildren; ++c) {
            if (node.mChildren == nullptr || node.mChildren[c] == nullptr)
                fail("a node of the scene is missing");
            walk(sc, *node.mChildren[c], m, depth + 1);
        }
    }

    // `name`, or `name.2`, `name.3`, ... when an earlier mesh took it.
    std::string unique(const std::string& name) {
        const int n = ++used_[name];
        if (n == 1) return name;
        return unique(name + "." + std::to_string(n));
    }

    // The material of a glTF mesh: base colour → reflectance, emissive (times its strength) →
    // emission. Other formats carry none we use: the default material.
    int material_of(const aiScene& sc, const aiMesh& mesh, const std::string& name) {
        if (!gltf_ || mesh.mMaterialIndex >= sc.mNumMaterials) return 0;
        const auto it = material_index_.find(mesh.mMaterialIndex);
        if (it != material_index_.end()) return it->second;
        const aiMaterial& am = *sc.mMaterials[mesh.mMaterialIndex];
        Material m;
        aiString mname;
        m.name = am.Get(AI_MATKEY_NAME, mname) == AI_SUCCESS && mname.length > 0
                     ? std::string(mname.C_Str())
                     : name;
        aiColor4D base(1, 1, 1, 1);
        if (am.Get(AI_MATKEY_BASE_COLOR, base) == AI_SUCCESS ||
            am.Get(AI_MATKEY_COLOR_DIFFUSE, base) == AI_SUCCESS)
            m.reflectance = Rgb(base.r, base.g, base.b);
        aiColor3D emissive(0, 0, 0);
        if (am.Get(AI_MATKEY_COLOR_EMISSIVE, emissive) == AI_SUCCESS) {
            float strength = 1.0f;
            am.Get(AI_MATKEY_EMISSIVE_INTENSITY, strength);
            m.emission = Rgb(emissive.r, emissive.g, emissive.b) * static_cast<double>(strength);
        }
        const std::string what = "material '" + m.name + "'";
        if (!m.reflectance.allFinite() || (m.reflectance.array() < 0).any() ||
            (m.reflectance.array() > 1).any())
            fail(what + ": base colour outside [0, 1]");
        if (!m.emission.allFinite() || (m.emission.array() < 0).any())
            fail(what + ": emission negative or not finite");
        scene_.materials.push_back(m);
        const int index = static_cast<int>(scene_.materials.size()) - 1;
        material_index_[mesh.mMaterialIndex] = index;
        return index;
    }

    void add_mesh(const aiScene& sc, const aiMesh& mesh, const Eigen::Matrix4d& m,
                  const std::string& name) {
        if (mesh.mNumVertices > 0 && mesh.mVertices == nullptr)
            fail("mesh '" + name + "' has no vertices");
        const int material = material_of(sc, mesh, name);
        const bool obstruction = is_obstruction_name(name);
        int first = -1;
        std::size_t kept = 0;
        for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
            const aiFace& face = mesh.mFaces[f];
            if (face.mNumIndices < 3) continue;  // points and lines
            const std::string what = "mesh '" + name + "' face " + std::to_string(f + 1);
            Surface s;
            s.name = name;
            s.obstruction = obstruction;
            s.material = material;
            s.where = {path_, 0};
            for (unsigned k = 0; k < face.mNumIndices; ++k) {
                const unsigned v = face.mIndices[k];
                if (v >= mesh.mNumVertices)
                    fail(what + " refers to vertex " + std::to_string(v) + " of " +
                         std::to_string(mesh.mNumVertices));
                const aiVector3D& p = mesh.mVertices[v];
                const Eigen::Vector4d x = m * Eigen::Vector4d(p.x, p.y, p.z, 1.0);
                s.polygon.vertices.emplace_back(x.x() / x.w(), x.y() / x.w(), x.z() / x.w());
            }
            validate_polygon(s.polygon, s.where, what);
            const int index = static_cast<int>(scene_.surfaces.size());
            if (first < 0)
                first = index;
            else if (!obstruction)
                s.combine = first;
            scene_.surfaces.push_back(std::move(s));
            ++kept;
        }
        if (kept == 0 && mesh.mNumFaces > 0)
            scene_.warnings.push_back(path_ + ": mesh '" + name +
                                      "' has no faces of three or more vertices (ignored)");
    }

    std::string path_;
    bool gltf_ = false;
    Scene scene_;
    std::map<std::string, int> used_;
    std::map<unsigned, int> material_index_;
};

}  // namespace

Scene load_mesh(const std::string& path) {
    Scene scene = AssimpReader(path).read();
    detail::require_surfaces(scene, path, "no faces", "meshes named obstruction* only block");
    subdivide(scene, SubdivisionOptions{});
    return scene;
}

}  // namespace formfactor
