#pragma once
// The bodies of the fuzz targets, shared with the regression tests
// (tests/test_fuzz_regressions.cpp): each feeds one input to one reader of the library. A
// formfactor::Error is the expected answer to bad input; anything else (another exception, a
// crash, a sanitizer report, a hang) is a bug.
//
// Readers that take only a path (OBJ + MTL, VS3) get the input written to a file in a private
// temporary directory (one per process, in memory where /dev/shm exists); the others read a
// stream.

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

#include "formfactor/core/error.h"
#include "formfactor/matrix/aggregate.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/scene/energyplus.h"
#include "formfactor/scene/mesh_io.h"
#include "formfactor/scene/points.h"
#include "formfactor/scene/scene.h"
#include "formfactor/solve/properties.h"

namespace formfactor::fuzz {

/// The readers under test.
enum class Target {
    obj,         ///< load_obj: the OBJ text, then optionally the line `#%mtl` and the MTL text
    vs3,         ///< load_vs3
    properties,  ///< apply_properties_csv on the built-in cube, 2×2 patches per face
    matrix_csv,  ///< read_csv_matrix
    matrix_npy,  ///< read_npy_matrix
    matrix_txt,  ///< read_view3d_text
    matrix_mtx,  ///< read_matrix_market (sparse F, Matrix Market coordinate)
    solution,    ///< read_solution_csv (radiosity and thermal tables)
    points,      ///< parse_points_csv (the point elements of `formfactor point --points`)
    idf,         ///< load_energyplus_text of an EnergyPlus IDF model (its only zone)
    epjson,      ///< load_energyplus_text of an EnergyPlus epJSON model (its only zone)
    matrix_dat,  ///< read_elmer_view_factors (Elmer's view-factor file)
    msh,         ///< load_msh (Gmsh, any version and encoding the bytes claim)
    mesh,        ///< load_mesh: the first byte picks the extension (kMeshExtensions), the rest
                 ///< is the file
};

struct TargetName {
    const char* name;
    Target target;
};

/// Every target with the name of its fuzzer (`fuzz_NAME`) and corpus folder.
inline constexpr std::array<TargetName, 14> kTargets = {{
    {"obj", Target::obj},
    {"vs3", Target::vs3},
    {"properties", Target::properties},
    {"matrix_csv", Target::matrix_csv},
    {"matrix_npy", Target::matrix_npy},
    {"matrix_txt", Target::matrix_txt},
    {"matrix_mtx", Target::matrix_mtx},
    {"solution", Target::solution},
    {"points", Target::points},
    {"idf", Target::idf},
    {"epjson", Target::epjson},
    {"matrix_dat", Target::matrix_dat},
    {"msh", Target::msh},
    {"mesh", Target::mesh},
}};

/// The extensions the `mesh` target writes its input as, picked by the input's first byte
/// (modulo their number).
inline constexpr std::array<const char*, 5> kMeshExtensions = {".stl", ".ply", ".off", ".gltf",
                                                               ".glb"};

/// The line that separates the OBJ text from the MTL text in an `obj` input. The MTL part is
/// written as `fuzz.mtl` beside `fuzz.obj`, so an OBJ that says `mtllib fuzz.mtl` reads it.
inline constexpr std::string_view kMtlSeparator = "\n#%mtl\n";

/// A private temporary directory, removed with its content when the process ends normally.
class Workspace {
  public:
    Workspace() {
        // In memory when the machine has /dev/shm: a file on disk costs ~5 ms per input.
        std::error_code ec;
        const std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec)
                                               ? std::filesystem::path("/dev/shm")
                                               : std::filesystem::temp_directory_path();
        std::string pattern = (base / "formfactor-fuzz-XXXXXX").string();
        if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
        dir_ = pattern;
    }
    ~Workspace() {
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }
    Workspace(const Workspace&) = delete;
    Workspace& operator=(const Workspace&) = delete;

    /// Writes `bytes` to dir/name and returns that path.
    std::string write(const std::string& name, std::string_view bytes) const {
        const std::string path = (dir_ / name).string();
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        if (!out) throw std::runtime_error("cannot write " + path);
        return path;
    }
    /// Removes dir/name if it exists.
    void remove(const std::string& name) const {
        std::error_code ec;
        std::filesystem::remove(dir_ / name, ec);
    }

  private:
    std::filesystem::path dir_;
};

/// The process's workspace.
inline Workspace& workspace() {
    static Workspace ws;
    return ws;
}

/// A property of what a reader accepted that does not hold: a bug, reported as an exception
/// that is not a formfactor::Error.
inline void require(bool ok, const char* what) {
    if (!ok) throw std::logic_error(std::string("fuzz invariant violated: ") + what);
}

/// What every accepted scene must satisfy.
inline void check_scene(const Scene& scene) {
    for (const Patch& p : scene.patches) {
        require(std::isfinite(p.area) && p.area > 0.0, "patch area finite and positive");
        require(p.normal.allFinite() && std::abs(p.normal.norm() - 1.0) < 1e-9,
                "patch normal finite and unit");
        require(p.centroid.allFinite(), "patch centroid finite");
        require(p.surface >= 0 && static_cast<std::size_t>(p.surface) < scene.surfaces.size(),
                "patch surface index valid");
    }
}

/// What the library does next with a scene it has read: more patches, properties, groups.
inline void exercise_scene(Scene& scene) {
    check_scene(scene);
    (void)properties_from_scene(scene);
    (void)surface_groups(scene);
    if (scene.surfaces.size() <= 64) {
        SubdivisionOptions options;
        options.n = 2;
        subdivide(scene, options);
        check_scene(scene);
    }
}

/// The scene the properties target applies its CSV to.
inline const Scene& properties_scene() {
    static const Scene scene = [] {
        Scene s = builtin_scene("cube");
        SubdivisionOptions options;
        options.n = 2;
        subdivide(s, options);
        return s;
    }();
    return scene;
}

/// Runs one input through one reader. Returns true when the reader accepted it, false when it
/// threw formfactor::Error; lets every other exception through (a bug).
inline bool run(Target target, const std::uint8_t* data, std::size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    const Workspace& ws = workspace();
    try {
        switch (target) {
            case Target::obj: {
                const std::size_t cut = bytes.find(kMtlSeparator);
                if (cut == std::string_view::npos) {
                    ws.remove("fuzz.mtl");
                } else {
                    ws.write("fuzz.mtl", bytes.substr(cut + kMtlSeparator.size()));
                }
                Scene scene = load_obj(ws.write("fuzz.obj", bytes.substr(0, cut)));
                exercise_scene(scene);
                break;
            }
            case Target::vs3: {
                Scene scene = load_vs3(ws.write("fuzz.vs3", bytes));
                exercise_scene(scene);
                break;
            }
            case Target::msh: {
                Scene scene = load_msh(ws.write("fuzz.msh", bytes));
                exercise_scene(scene);
                break;
            }
            case Target::mesh: {
                if (bytes.empty()) break;
                const char* ext =
                    kMeshExtensions[static_cast<unsigned char>(bytes[0]) % kMeshExtensions.size()];
                Scene scene = load_mesh(ws.write(std::string("fuzz") + ext, bytes.substr(1)));
                exercise_scene(scene);
                break;
            }
            case Target::properties: {
                const Scene& scene = properties_scene();
                PatchProperties props = properties_from_scene(scene);
                std::istringstream in{std::string(bytes)};
                apply_properties_csv(in, "fuzz.csv", scene, props);
                try {
                    validate_properties(props);
                } catch (const Error&) {
                    require(false, "properties the reader accepted are valid");
                }
                break;
            }
            case Target::matrix_csv: {
                std::istringstream in{std::string(bytes)};
                require(read_csv_matrix(in, "fuzz.csv").allFinite(), "matrix values finite");
                break;
            }
            case Target::matrix_npy: {
                std::istringstream in{std::string(bytes)};
                require(read_npy_matrix(in, "fuzz.npy").allFinite(), "matrix values finite");
                break;
            }
            case Target::matrix_txt: {
                std::istringstream in{std::string(bytes)};
                const View3dFile f = read_view3d_text(in, "fuzz.txt");
                require(f.F.allFinite(), "matrix values finite");
                require(f.areas.size() == static_cast<std::size_t>(f.F.rows()) &&
                            f.emissivities.size() == f.areas.size() && f.F.rows() == f.F.cols(),
                        "sizes agree");
                break;
            }
            case Target::matrix_mtx: {
                std::istringstream in{std::string(bytes)};
                SparseFormFactors F = read_matrix_market(in, "fuzz.mtx");
                F.areas.assign(F.n, 1.0);
                F.check();  // throws formfactor::Error: a bug here, the reader promised CSR
                require(F.computed_row_sums.size() == F.n && F.dropped.size() == F.n,
                        "per-row arrays");
                break;
            }
            case Target::solution: {
                std::istringstream in{std::string(bytes)};
                const SolutionTable t = read_solution_csv(in, "fuzz.csv");
                std::istringstream again{std::string(bytes)};
                require(read_solution_csv(again, "fuzz.csv", t.size()).size() == t.size(),
                        "same table");
                if (t.thermal)
                    require(t.area.size() == t.size() && t.net_power.size() == t.size(),
                            "thermal columns sized");
                break;
            }
            case Target::points: {
                std::istringstream in{std::string(bytes)};
                const PointElements p = parse_points_csv(in, "fuzz.csv");
                require(!p.positions.empty() && p.normals.size() == p.positions.size() &&
                            p.lines.size() == p.positions.size(),
                        "one normal and one line per point");
                for (std::size_t k = 0; k < p.positions.size(); ++k) {
                    require(p.positions[k].allFinite(), "positions finite");
                    require(p.normals[k].allFinite() && std::abs(p.normals[k].norm() - 1.0) < 1e-12,
                            "normals finite and unit");
                    require(p.lines[k] >= 1 && (k == 0 || p.lines[k] > p.lines[k - 1]),
                            "lines increasing");
                }
                break;
            }
            case Target::idf: {
                Scene scene = load_energyplus_text(std::string(bytes), "fuzz.idf");
                require(scene.enclosure && !scene.surfaces.empty(), "a zone with surfaces");
                exercise_scene(scene);
                break;
            }
            case Target::epjson: {
                // The extension picks the JSON grammar; its objects are read by code of their own.
                Scene scene = load_energyplus_text(std::string(bytes), "fuzz.epJSON");
                require(scene.enclosure && !scene.surfaces.empty(), "a zone with surfaces");
                exercise_scene(scene);
                break;
            }
            case Target::matrix_dat: {
                std::istringstream in{std::string(bytes)};
                const DenseMatrix F = read_elmer_view_factors(in, "fuzz.dat");
                require(F.allFinite() && F.rows() == F.cols() && F.rows() > 0,
                        "a square finite matrix");
                break;
            }
        }
    } catch (const Error&) {
        return false;
    }
    return true;
}

}  // namespace formfactor::fuzz
