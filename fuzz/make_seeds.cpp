// Writes the seed corpus of every fuzz target: `fuzz_seeds TESTS_DATA_DIR OUT_DIR` fills
// OUT_DIR/<target>/ from the test fixtures (tests/data), the built-in scenes as our own writers
// write them, small matrices and tables from our writers, a few hand-written variants, and the
// regression inputs (tests/data/fuzz_regressions/<target>/). Nothing binary is committed: the
// seeds are made here, at build or run time.

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "formfactor/output/matrix_io.h"
#include "formfactor/output/solution_io.h"
#include "formfactor/output/sparse_io.h"
#include "formfactor/scene/scene.h"
#include "formfactor/scene/scene_io.h"
#include "fuzz/harness.h"

namespace fs = std::filesystem;
using namespace formfactor;

namespace {

std::string read_file(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class Seeds {
  public:
    explicit Seeds(fs::path dir) : dir_(std::move(dir)) {}
    void add(const std::string& target, const std::string& name, const std::string& bytes) {
        const fs::path d = dir_ / target;
        fs::create_directories(d);
        std::ofstream out(d / name, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        ++count_;
    }
    int count() const { return count_; }

  private:
    fs::path dir_;
    int count_ = 0;
};

// An OBJ input for the obj target: the OBJ text with its mtllib pointing at fuzz.mtl, the
// separator, the MTL text.
std::string obj_input(std::string obj, const std::string& mtl) {
    std::istringstream in(obj);
    std::string line, out;
    while (std::getline(in, line)) {
        if (line.rfind("mtllib", 0) == 0) line = "mtllib fuzz.mtl";
        (out += line) += '\n';
    }
    if (mtl.empty()) return out;
    if (!out.empty() && out.back() == '\n') out.pop_back();
    return out + std::string(fuzz::kMtlSeparator) + mtl;
}

DenseMatrix small_matrix(int n) {
    DenseMatrix F(n, n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) F(i, j) = i == j ? 0.0 : 1.0 / (1.0 + i + 2.0 * j);
    if (n > 2) {
        F(0, 1) = 1e-300;
        F(1, 2) = std::numeric_limits<double>::denorm_min();
        F(2, 0) = -0.0;
    }
    return F;
}

template <class Write>
std::string to_bytes(Write write) {
    std::ostringstream out(std::ios::binary);
    write(out);
    return out.str();
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: fuzz_seeds TESTS_DATA_DIR OUT_DIR\n");
        return 2;
    }
    const fs::path data = argv[1];
    Seeds seeds(argv[2]);
    fs::remove_all(argv[2]);

    // Scenes: the fixtures, then every built-in scene as save_obj / save_vs3 write it.
    for (const auto& e : fs::directory_iterator(data)) {
        const fs::path p = e.path();
        if (p.extension() == ".vs3") seeds.add("vs3", p.filename().string(), read_file(p));
        if (p.extension() == ".obj") {
            fs::path mtl = p;
            mtl.replace_extension(".mtl");
            seeds.add("obj", p.filename().string(),
                      obj_input(read_file(p), fs::exists(mtl) ? read_file(mtl) : ""));
        }
    }
    for (const auto& e : fs::directory_iterator(data / "gmsh"))
        if (e.path().extension() == ".msh")
            seeds.add("msh", e.path().filename().string(), read_file(e.path()));
    // Meshes: the mesh target's first byte picks the extension (fuzz::kMeshExtensions).
    const std::string tri = "0 0 0\n1 0 0\n0 1 0\n";
    seeds.add("mesh", "triangle.stl",
              std::string(1, '\0') +
                  "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                  "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
    seeds.add("mesh", "triangle.ply",
              std::string(1, '\1') +
                  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float "
                  "y\nproperty float z\nelement face 1\nproperty list uchar int "
                  "vertex_indices\nend_header\n" +
                  tri + "3 0 1 2\n");
    seeds.add("mesh", "triangle.off", std::string(1, '\2') + "OFF\n3 1 0\n" + tri + "3 0 1 2\n");
    const fuzz::Workspace ws;
    for (const std::string& name : builtin_scene_names()) {
        const Scene scene = builtin_scene(name);
        const std::string obj = ws.write("scene.obj", "");
        save_obj(scene, obj);
        const fs::path mtl = fs::path(obj).replace_extension(".mtl");
        seeds.add("obj", name + ".obj",
                  obj_input(read_file(obj), fs::exists(mtl) ? read_file(mtl) : ""));
        const std::string vs3 = ws.write("scene.vs3", "");
        try {
            save_vs3(scene, vs3);
            seeds.add("vs3", name + ".vs3", read_file(vs3));
        } catch (const Error&) {
            // a scene View3D cannot express
        }
    }
    seeds.add("obj", "features.obj",
              "# groups, objects, obstructions, relative indices, vt/vn, ignored records\n"
              "mtllib fuzz.mtl\no box\ng floor\nusemtl white\nv 0 0 0\nv 1 0 0\nv 1 1 0\n"
              "v 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3//1 4\ng obstruction_plate\n"
              "v 0.2 0.2 0.5\nv 0.8 0.2 0.5\nv 0.5 0.8 0.5\nf -3 -2 -1\ns off\nl 1 2\n"
              "g ceiling\nusemtl lamp\nv 0 0 1\nv 0 1 1\nv 1 1 1\nv 1 0 1\nf -4 -3 -2 -1\n"
              "#%mtl\nnewmtl white\nKd 0.8\nemissivity 0.9\nnewmtl lamp\nKd 0.1 0.2 0.3\n"
              "Ke 10 10 10\ntemperature 300\n");

    // Properties for the cube, 2×2 patches per face (24 patches; surfaces x0 … z1).
    seeds.add("properties", "by_patch.csv",
              "patch,reflectance_r,reflectance_g,reflectance_b,emission_r,emission_g,emission_b\n"
              "0,0.5,0.5,0.5,1,1,1\n# a comment\n\n23,0.1,0.2,0.3,,,\n");
    seeds.add("properties", "by_surface.csv",
              "surface,emissivity,temperature,net_flux\nx0,0.9,300,\n\"z1\",0.5,,100\n"
              "y0,1,0,\n");

    // Matrices: our writers' output.
    for (int n : {1, 2, 5}) {
        const DenseMatrix F = small_matrix(n);
        const std::string tag = std::to_string(n);
        seeds.add("matrix_csv", tag + ".csv",
                  to_bytes([&](std::ostream& o) { write_csv_matrix(o, F); }));
        seeds.add("matrix_npy", tag + ".npy",
                  to_bytes([&](std::ostream& o) { write_npy_matrix(o, F); }));
        MatrixFileInfo info;
        info.areas.assign(static_cast<std::size_t>(n), 0.25);
        info.enclosure = n == 5;
        seeds.add("matrix_txt", tag + ".txt",
                  to_bytes([&](std::ostream& o) { write_view3d_text(o, F, info); }));
    }
    seeds.add("matrix_csv", "comments.csv", "# F\n0, 0.5\n\n  0.25 ,0\n");
    for (int n : {1, 2, 5}) {
        FormFactors ff;
        ff.F = small_matrix(n);
        ff.areas.assign(static_cast<std::size_t>(n), 0.25);
        const SparseFormFactors S = to_sparse(ff);
        seeds.add("matrix_mtx", std::to_string(n) + ".mtx",
                  to_bytes([&](std::ostream& o) { write_matrix_market(o, S); }));
    }
    seeds.add("matrix_mtx", "unordered.mtx",
              "%%MatrixMarket matrix coordinate real general\n% any order\n3 3 3\n3 1 0.25\n"
              "1 2 5e-1\n2 3 1\n");
    {
        // float32, Fortran order, NPY version 2.0.
        std::string dict = "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 3), }";
        while ((dict.size() + 13) % 64 != 0) dict += ' ';
        dict += '\n';
        std::string npy = std::string("\x93NUMPY\x02\x00", 8);
        const std::uint32_t len = static_cast<std::uint32_t>(dict.size());
        for (int b = 0; b < 4; ++b) npy += static_cast<char>((len >> (8 * b)) & 0xff);
        npy += dict;
        for (int k = 0; k < 6; ++k) {
            const float v = 0.125f * static_cast<float>(k);
            char raw[4];
            std::memcpy(raw, &v, 4);
            npy.append(raw, 4);
        }
        seeds.add("matrix_npy", "f4_fortran_v2.npy", npy);
    }

    // Solution tables.
    {
        std::vector<Rgb> b = {Rgb(1, 2, 3), Rgb(0, 0.5, 1e-9), Rgb(7, 7, 7)};
        seeds.add("solution", "radiosity.csv", radiosity_csv_text(b));
        ThermalResult r;
        r.area = {1, 2};
        r.emissivity = {0.9, 0.5};
        r.temperature = {300, 400};
        r.temperature_prescribed = {true, false};
        r.radiosity = {400, 1200.5};
        r.net_flux = {-10, 10};
        r.net_power = {-10, 20};
        seeds.add("solution", "thermal.csv", thermal_csv_text(r));
    }

    // Point elements (`formfactor point --points`).
    seeds.add("points", "header.csv",
              "x,y,z,nx,ny,nz\n# sensors\n0.5, 0.5, 0, 0, 0, 1\n\n1 2 3 0 1 0  # spaces\n");
    seeds.add("points", "plain.csv", "0,0,0,0,0,1\n1e-3,-2.5e+2,7,1,1,1\r\n");

    // EnergyPlus models (tests/data/energyplus) and Elmer view-factor files.
    for (const auto& e : fs::directory_iterator(data / "energyplus"))
        if (e.path().extension() == ".idf")
            seeds.add("idf", e.path().filename().string(), read_file(e.path()));
        else if (e.path().extension() == ".epJSON")
            seeds.add("epjson", e.path().filename().string(), read_file(e.path()));
    seeds.add("idf", "relative.idf",
              "Zone,Z,30,1,2,3;GlobalGeometryRules,LowerLeftCorner,Clockwise,Relative;\n"
              "Floor:Detailed,F,C,Z,,Ground,,NoSun,NoWind,,3,0,0,0,1,0,0,0,1,0;\n"
              "Wall:Detailed,W,C,Z,,Outdoors,,SunExposed,WindExposed,,3,0,0,0,0,1,0,0,0,1;\n");
    seeds.add(
        "epjson", "two_surfaces.epJSON",
        R"({"Zone": {"Z": {}}, "GlobalGeometryRules": {"G": {"starting_vertex_position": )"
        R"("UpperLeftCorner", "vertex_entry_direction": "Counterclockwise", )"
        R"("coordinate_system": "World"}}, "BuildingSurface:Detailed": {"F": {"surface_type": )"
        R"("Floor", "zone_name": "Z", "vertices": [{"vertex_x_coordinate": 0, )"
        R"("vertex_y_coordinate": 0, "vertex_z_coordinate": 0}, {"vertex_x_coordinate": 0, )"
        R"("vertex_y_coordinate": 1, "vertex_z_coordinate": 0}, {"vertex_x_coordinate": 1, )"
        R"("vertex_y_coordinate": 0, "vertex_z_coordinate": 0}]}}})");
    // Simplified windows placed on detailed walls and roofs (entered clockwise).
    seeds.add("idf", "window_on_detailed.idf",
              "Version,9.3;Zone,Z;GlobalGeometryRules,UpperLeftCorner,Clockwise,World;\n"
              "BuildingSurface:Detailed,S,Wall,C,Z,Outdoors,,,,,4,0,0,2,4,0,2,4,0,0,0,0,0;\n"
              "Window,SW,G,S,,1,1,0.5,1,1;\n"
              "BuildingSurface:Detailed,R,Roof,C,Z,Outdoors,,,,,4,0,3,2,4,3,2,4,0,2,0,0,2;\n"
              "Door,RD,D,R,1,1,1,1,0.5;\n"
              "BuildingSurface:Detailed,F,Floor,C,Z,Ground,,,,,4,4,3,0,0,3,0,0,0,0,4,0,0;\n");
    {
        std::ostringstream dat;
        DenseMatrix F(3, 3);
        F << 0, 0.5, 0.5, 0.25, 0, 0.75, 1e-300, 0, 0;
        write_elmer_view_factors(dat, F);
        seeds.add("matrix_dat", "three.dat", dat.str());
    }

    // The regression inputs: every input that once crashed stays in the corpus.
    const fs::path regressions = data / "fuzz_regressions";
    for (const auto& t : fuzz::kTargets) {
        const fs::path d = regressions / t.name;
        if (!fs::is_directory(d)) continue;
        for (const auto& e : fs::directory_iterator(d))
            seeds.add(t.name, "regression-" + e.path().filename().string(), read_file(e.path()));
    }
    std::printf("fuzz_seeds: %d seed inputs in %s\n", seeds.count(), argv[2]);
    return 0;
}
