#pragma once
// The extension of a path, lower-case with its dot (".npy"), for choosing a file format.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

namespace formfactor::detail {

inline std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

}  // namespace formfactor::detail
