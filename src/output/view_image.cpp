#include "formfactor/output/view_image.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"

namespace formfactor {

namespace {

std::array<std::uint8_t, 3> hsv(double h, double s, double v) {
    h = (h - std::floor(h)) * 6.0;
    const int i = static_cast<int>(h) % 6;
    const double f = h - std::floor(h);
    const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    double r = v, g = t, b = p;
    switch (i) {
        case 1:
            r = q, g = v, b = p;
            break;
        case 2:
            r = p, g = v, b = t;
            break;
        case 3:
            r = p, g = q, b = v;
            break;
        case 4:
            r = t, g = p, b = v;
            break;
        case 5:
            r = v, g = p, b = q;
            break;
        default:
            break;
    }
    auto byte = [](double x) {
        return static_cast<std::uint8_t>(std::clamp(std::lround(x * 255.0), 0L, 255L));
    };
    return {byte(r), byte(g), byte(b)};
}

// A perceptually ordered ramp (after viridis): dark blue → teal → green → yellow.
std::array<std::uint8_t, 3> ramp(double t) {
    static constexpr double kStops[6][3] = {{68, 1, 84},   {59, 82, 139},  {33, 145, 140},
                                            {94, 201, 98}, {189, 223, 38}, {253, 231, 37}};
    t = std::clamp(t, 0.0, 1.0) * 5.0;
    const int i = std::min(4, static_cast<int>(t));
    const double f = t - i;
    std::array<std::uint8_t, 3> c{};
    for (int k = 0; k < 3; ++k) {
        c[static_cast<std::size_t>(k)] =
            static_cast<std::uint8_t>(std::lround(kStops[i][k] * (1 - f) + kStops[i + 1][k] * f));
    }
    return c;
}

Image blank(const ProjectionView& view, int scale) {
    if (scale < 1) throw OptionError("scale", "must be at least 1");
    if (view.width <= 0 || view.height <= 0 ||
        view.items.size() != static_cast<std::size_t>(view.width) * view.height) {
        throw Error("view image: the view is empty or inconsistent");
    }
    Image img;
    img.width = view.width * scale;
    img.height = view.height * scale;
    img.rgb.assign(static_cast<std::size_t>(img.width) * img.height * 3, 0);
    return img;
}

void put(Image& img, int scale, int col, int row, const std::array<std::uint8_t, 3>& c) {
    for (int y = row * scale; y < (row + 1) * scale; ++y) {
        for (int x = col * scale; x < (col + 1) * scale; ++x) {
            std::uint8_t* p = img.rgb.data() + (static_cast<std::size_t>(y) * img.width + x) * 3;
            p[0] = c[0];
            p[1] = c[1];
            p[2] = c[2];
        }
    }
}

double max_delta(const ProjectionView& view) {
    double m = 0.0;
    for (double d : view.delta) m = std::max(m, d);
    return m;
}

}  // namespace

std::array<std::uint8_t, 3> item_colour(int item) {
    switch (item) {
        case kViewNothing:
            return {0, 0, 0};
        case kViewBackFace:
            return {64, 64, 64};
        case kViewObstruction:
            return {40, 40, 40};
        case kViewUnused:
            return {255, 255, 255};
        default:
            break;
    }
    if (item < 0) return {0, 0, 0};
    // Golden-ratio hues; saturation and value cycle too, so that ids far apart in a large
    // scene rarely share a colour.
    const auto u = static_cast<unsigned>(item);
    const double h = 0.11 + 0.6180339887498949 * u;
    const double s = 0.55 + 0.15 * ((u * 7u) % 3u);
    const double v = 0.70 + 0.12 * ((u * 5u) % 3u);
    return hsv(h, s, v);
}

Image render_view(const ProjectionView& view, bool weights, int scale) {
    Image img = blank(view, scale);
    const double dmax = max_delta(view);
    for (int row = 0; row < view.height; ++row) {
        for (int col = 0; col < view.width; ++col) {
            const std::size_t k = static_cast<std::size_t>(row) * view.width + col;
            auto c = item_colour(view.items[k]);
            if (weights && view.items[k] != kViewUnused && dmax > 0.0) {
                const double w = view.delta[k] / dmax;
                for (auto& ch : c) ch = static_cast<std::uint8_t>(std::lround(ch * w));
            }
            put(img, scale, col, row, c);
        }
    }
    return img;
}

Image render_delta_map(const ProjectionView& view, int scale) {
    Image img = blank(view, scale);
    const double dmax = max_delta(view);
    for (int row = 0; row < view.height; ++row) {
        for (int col = 0; col < view.width; ++col) {
            const std::size_t k = static_cast<std::size_t>(row) * view.width + col;
            const auto c = view.items[k] == kViewUnused
                               ? std::array<std::uint8_t, 3>{255, 255, 255}
                               : ramp(dmax > 0.0 ? view.delta[k] / dmax : 0.0);
            put(img, scale, col, row, c);
        }
    }
    return img;
}

}  // namespace formfactor
