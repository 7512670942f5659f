#pragma once
// Helpers of the scene tests: scratch files, fixtures in tests/data and error messages.

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "formfactor/core/error.h"
#include "formfactor/scene/scene.h"
#include "temp_dir.h"

namespace formfactor::testing {

/// A scratch folder of this test process (a TempDir, removed when the process exits).
inline const std::filesystem::path& scratch_dir() {
    static const TempDir dir;
    return dir.path();
}

/// Writes `text` to a file in scratch_dir() and returns its path.
inline std::string write_file(const std::string& name, const std::string& text) {
    const std::string p = (scratch_dir() / name).string();
    write_text(p, text);
    return p;
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

}  // namespace formfactor::testing
