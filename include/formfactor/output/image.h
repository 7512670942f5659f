#pragma once
/// The one image type of the library (renders of a solution, views of a projection method) and
/// its PNG encoding.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace formfactor {

/// An 8-bit sRGB image, rows top to bottom, 3 bytes per pixel.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgb;
    std::uint8_t* pixel(int x, int y) {
        return rgb.data() + 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                 static_cast<std::size_t>(x));
    }
    const std::uint8_t* pixel(int x, int y) const {
        return rgb.data() + 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                 static_cast<std::size_t>(x));
    }
};

/// The PNG file's bytes (stb_image_write). Throws Error for an empty or inconsistent image.
std::string encode_png(const Image& image);

/// Writes a PNG (atomically: write_file_atomically(), formfactor/core/atomic_file.h). Throws
/// Error as encode_png(), InputError(path, 0, ...) when it cannot be written; nothing is left
/// behind.
void write_png(const std::string& path, const Image& image);

}  // namespace formfactor
