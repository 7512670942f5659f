#include "formfactor/output/image.h"

#include <stb/stb_image_write.h>

#include "formfactor/core/error.h"
#include "output/render_internal.h"

namespace formfactor {

std::string encode_png(const Image& image) {
    if (image.width < 1 || image.height < 1 ||
        image.rgb.size() !=
            static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 3)
        throw Error("write_png: empty or inconsistent image");
    std::string bytes;
    auto sink = [](void* ctx, void* data, int size) {
        static_cast<std::string*>(ctx)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
    };
    if (!stbi_write_png_to_func(sink, &bytes, image.width, image.height, 3, image.rgb.data(),
                                image.width * 3))
        throw Error("PNG encoding failed");
    return bytes;
}

void write_png(const std::string& path, const Image& image) {
    detail::write_bytes_atomically(path, encode_png(image));
}

}  // namespace formfactor
