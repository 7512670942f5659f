// Text for the colour bar, through stb_easy_font (public domain, header-only, in libstb-dev):
// it turns a string into axis-aligned quads, which are filled here at an integer scale.

#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#endif
#include <stb/stb_easy_font.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "output/render_internal.h"

namespace formfactor::detail {

namespace {

struct FontVertex {
    float x, y, z;
    unsigned char colour[4];
};

}  // namespace

int text_width(const std::string& text, int scale) {
    std::vector<char> s(text.begin(), text.end());
    s.push_back('\0');
    return stb_easy_font_width(s.data()) * scale;
}

int text_height(int scale) { return 12 * scale; }

void draw_text(Image& image, int x, int y, const std::string& text, int scale,
               const std::array<std::uint8_t, 3>& colour) {
    if (text.empty()) return;
    std::vector<char> s(text.begin(), text.end());
    s.push_back('\0');
    std::vector<FontVertex> buffer(text.size() * 80 + 64);
    const int quads = stb_easy_font_print(0.0f, 0.0f, s.data(), nullptr, buffer.data(),
                                          static_cast<int>(buffer.size() * sizeof(FontVertex)));
    // The glyphs start about 1 unit below y; their cap height is ~7 units.
    const int y0 = y + 2 * scale;
    for (int q = 0; q < quads; ++q) {
        const FontVertex* v = &buffer[static_cast<std::size_t>(4 * q)];
        float lx = v[0].x, hx = v[0].x, ly = v[0].y, hy = v[0].y;
        for (int k = 1; k < 4; ++k) {
            lx = std::min(lx, v[k].x);
            hx = std::max(hx, v[k].x);
            ly = std::min(ly, v[k].y);
            hy = std::max(hy, v[k].y);
        }
        const int px0 = x + static_cast<int>(std::lround(lx * scale));
        const int px1 = x + static_cast<int>(std::lround(hx * scale));
        const int py0 = y0 + static_cast<int>(std::lround(ly * scale));
        const int py1 = y0 + static_cast<int>(std::lround(hy * scale));
        for (int py = std::max(0, py0); py < std::min(image.height, py1); ++py)
            for (int px = std::max(0, px0); px < std::min(image.width, px1); ++px)
                std::memcpy(image.pixel(px, py), colour.data(), 3);
    }
}

}  // namespace formfactor::detail
