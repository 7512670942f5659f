#pragma once
// Helpers of the scene tests: scratch files and error messages.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"

namespace formfactor::test {

/// A scratch folder for this test process.
inline std::filesystem::path scratch_dir() {
    const auto d = std::filesystem::temp_directory_path() /
                   ("formfactor_scene_tests_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
}

/// Writes `text` to a scratch file and returns its path.
inline std::string write_file(const std::string& name, const std::string& text) {
    const auto p = scratch_dir() / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
}

/// The message of the InputError that `f` throws ("" when it throws none).
inline std::string input_error(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

/// The path of a fixture in tests/data.
inline std::string data(const std::string& name) {
    return std::string(FF_TEST_DATA_DIR) + "/" + name;
}

/// True when the polygons have the same vertices in the same cyclic order.
inline bool same_cycle(const Polygon& a, const Polygon& b, double tol = 1e-12) {
    if (a.size() != b.size()) return false;
    const std::size_t n = a.size();
    for (std::size_t s = 0; s < n; ++s) {
        bool ok = true;
        for (std::size_t k = 0; k < n && ok; ++k) ok = (a[k] - b[(k + s) % n]).norm() <= tol;
        if (ok) return true;
    }
    return false;
}

}  // namespace formfactor::test
