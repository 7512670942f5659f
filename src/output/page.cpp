// The result page (formfactor/output/page.h): the data block as JSON with deflated, base64
// binary arrays, and the HTML around it with the bundled script and style (page_bundle.h).

#include "formfactor/output/page.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <optional>
#include <ostream>
#include <unordered_map>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/geometry/polygon.h"
#include "formfactor/output/render.h"
#include "output/page_bundle.h"
#include "output/render_internal.h"

namespace formfactor {

namespace {

std::string base64(const void* data, std::size_t bytes) {
    static constexpr char kAlphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const auto* p = static_cast<const unsigned char*>(data);
    std::string out;
    out.reserve((bytes + 2) / 3 * 4);
    std::size_t k = 0;
    for (; k + 3 <= bytes; k += 3) {
        const std::uint32_t v = (p[k] << 16) | (p[k + 1] << 8) | p[k + 2];
        out += kAlphabet[v >> 18];
        out += kAlphabet[(v >> 12) & 63];
        out += kAlphabet[(v >> 6) & 63];
        out += kAlphabet[v & 63];
    }
    if (k < bytes) {
        const std::uint32_t v = (p[k] << 16) | (k + 1 < bytes ? p[k + 1] << 8 : 0);
        out += kAlphabet[v >> 18];
        out += kAlphabet[(v >> 12) & 63];
        out += k + 1 < bytes ? kAlphabet[(v >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

// zlib's format (RFC 1950), which the page inflates with the browser's own
// DecompressionStream('deflate'). The default level: 9 makes F's arrays 4% smaller and takes
// seven times as long.
std::string deflate(const void* data, std::size_t bytes) {
    uLongf size = compressBound(bytes);
    std::string out(size, '\0');
    if (compress2(reinterpret_cast<Bytef*>(out.data()), &size, static_cast<const Bytef*>(data),
                  bytes, Z_DEFAULT_COMPRESSION) != Z_OK)
        throw Error("the page's data could not be compressed (zlib)");
    out.resize(size);
    return out;
}

// How an array's bytes are laid out before they are deflated: by byte planes (every value's
// first byte, then every second byte, ...), which line up the exponents of floats and the high
// bytes of indices (F's values deflate a seventh smaller, triangle indices 7 to 10 times), or as
// they are, which suits vertex coordinates and Monte-Carlo standard errors (half the size of
// their planes). Chosen by what the array holds, so that each array is deflated once.
enum class Bytes { planes, as_is };

// Deflates `bytes` in zlib's format with a full flush after each segment: the compressed offset
// where each segment starts (and where the last one ends) goes to `starts`. After a full flush
// the compressor keeps no history and the stream is byte-aligned, so the page inflates one
// segment alone (raw deflate from its start, closed by an empty final block) and the whole
// stream still inflates as one.
std::string deflate_segments(const char* data, const std::vector<std::size_t>& segment_bytes,
                             std::vector<std::size_t>& starts) {
    z_stream z{};
    if (deflateInit(&z, Z_DEFAULT_COMPRESSION) != Z_OK)
        throw Error("the page's data could not be compressed (zlib)");
    std::string out(deflateBound(&z, segment_bytes.back()) + 16 * segment_bytes.size() + 64, '\0');
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(out.size());
    const auto produced = [&] { return out.size() - z.avail_out; };
    // The zlib header (2 bytes) comes first; a flush with nothing new to flush (an empty
    // segment) is no progress (Z_BUF_ERROR), not an error.
    int status = Z_OK;
    starts.push_back(2);
    for (std::size_t k = 0; k + 1 < segment_bytes.size() && status == Z_OK; ++k) {
        z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data + segment_bytes[k]));
        z.avail_in = static_cast<uInt>(segment_bytes[k + 1] - segment_bytes[k]);
        status = deflate(&z, Z_FULL_FLUSH);
        if (status == Z_BUF_ERROR && z.avail_in == 0) status = Z_OK;
        starts.push_back(produced());
    }
    if (status == Z_OK) status = deflate(&z, Z_FINISH);
    deflateEnd(&z);
    if (status != Z_STREAM_END || z.avail_in != 0)
        throw Error("the page's data could not be compressed (zlib)");
    out.resize(produced());
    return out;
}

// The page's typed arrays: {dtype, count, compression, base64} of little-endian values (x86 and
// ARM are), deflated: the file is what the browser reads before the page can start. With
// `segments` (value offsets, first 0, last the count), the array is stored in those segments
// ("segments" and the compressed offsets "segment_bytes" in the entry): byte planes are laid
// out segment by segment and the page can inflate a segment alone (deflate_segments).
template <class T>
nlohmann::json typed(const std::vector<T>& v, const char* dtype, Bytes layout = Bytes::planes,
                     const std::vector<std::size_t>* segments = nullptr) {
    const std::size_t bytes = v.size() * sizeof(T);
    std::vector<std::size_t> bounds = segments ? *segments : std::vector<std::size_t>{0, v.size()};
    std::string laid_out;
    const char* p = reinterpret_cast<const char*>(v.data());
    if (layout == Bytes::planes) {
        laid_out.assign(bytes, '\0');
        for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
            const std::size_t a = bounds[s], count = bounds[s + 1] - a;
            char* plane = laid_out.data() + a * sizeof(T);
            for (std::size_t k = 0; k < count; ++k)
                for (std::size_t b = 0; b < sizeof(T); ++b)
                    plane[b * count + k] = p[(a + k) * sizeof(T) + b];
        }
        p = laid_out.data();
    }
    std::string packed;
    std::vector<std::size_t> starts;
    if (segments) {
        std::vector<std::size_t> segment_bytes(bounds.size());
        for (std::size_t s = 0; s < bounds.size(); ++s) segment_bytes[s] = bounds[s] * sizeof(T);
        packed = deflate_segments(p, segment_bytes, starts);
    } else {
        packed = deflate(p, bytes);
    }
    nlohmann::json j = {{"dtype", dtype},
                        {"count", v.size()},
                        {"compression", "deflate"},
                        {"base64", base64(packed.data(), packed.size())}};
    if (layout == Bytes::planes) j["byte_planes"] = true;
    if (segments) {
        j["segments"] = bounds;
        j["segment_bytes"] = starts;
    }
    return j;
}
nlohmann::json f32(const std::vector<float>& v, Bytes layout = Bytes::planes,
                   const std::vector<std::size_t>* segments = nullptr) {
    return typed(v, "f32", layout, segments);
}
nlohmann::json f64(const std::vector<double>& v) { return typed(v, "f64"); }
nlohmann::json u32(const std::vector<std::uint32_t>& v) { return typed(v, "u32"); }
// Column indices in 2 bytes each when every index fits (N ≤ 65,536), else 4; each after the
// first of its row as the step from the one before, which deflates a fifth smaller.
nlohmann::json row_delta_indices(const std::vector<std::uint32_t>& row_ptr,
                                 const std::vector<std::uint32_t>& col, std::size_t n,
                                 const std::vector<std::size_t>& segments) {
    std::vector<std::uint32_t> steps(col.size());
    for (std::size_t i = 0; i + 1 < row_ptr.size(); ++i)
        for (std::uint32_t k = row_ptr[i]; k < row_ptr[i + 1]; ++k)
            steps[k] = k > row_ptr[i] ? col[k] - col[k - 1] : col[k];
    if (n > 65536) return typed(steps, "u32", Bytes::planes, &segments);
    return typed(std::vector<std::uint16_t>(steps.begin(), steps.end()), "u16", Bytes::planes,
                 &segments);
}

// The distinct (value, standard error) pairs of F's stored entries, most frequent first, and
// each entry's pair as a u16 index: a Monte-Carlo estimate is a hit count over the samples (the
// 10,580-patch Cornell box has 7,055 pairs among 13.4 million entries), and the indices deflate
// to about half of the two float32s. Used when there are at least 65,536 entries and at most a
// sixteenth as many pairs (and at most 65,536); nullopt otherwise.
struct Palette {
    std::vector<float> val, se;
    std::vector<std::uint16_t> index;
};
std::optional<Palette> palette_of(const std::vector<float>& val, const std::vector<float>& se) {
    if (val.size() < 65536) return std::nullopt;
    const std::size_t limit = std::min<std::size_t>(65536, val.size() / 16);
    const bool has_se = !se.empty();
    std::unordered_map<std::uint64_t, std::uint32_t> id;
    std::vector<std::uint64_t> keys;
    std::vector<std::size_t> count;
    std::vector<std::uint32_t> first(val.size());
    for (std::size_t k = 0; k < val.size(); ++k) {
        std::uint32_t v = 0, e = 0;
        std::memcpy(&v, &val[k], sizeof v);
        if (has_se) std::memcpy(&e, &se[k], sizeof e);
        const std::uint64_t key = (std::uint64_t{v} << 32) | e;
        const auto [at, fresh] = id.try_emplace(key, static_cast<std::uint32_t>(keys.size()));
        if (fresh) {
            if (keys.size() == limit) return std::nullopt;
            keys.push_back(key);
            count.push_back(0);
        }
        ++count[at->second];
        first[k] = at->second;
    }
    std::vector<std::uint32_t> order(keys.size()), rank(keys.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return count[a] > count[b]; });
    Palette p;
    for (std::size_t r = 0; r < order.size(); ++r) {
        rank[order[r]] = static_cast<std::uint32_t>(r);
        const std::uint64_t key = keys[order[r]];
        const auto v = static_cast<std::uint32_t>(key >> 32), e = static_cast<std::uint32_t>(key);
        float fv = 0.0f, fe = 0.0f;
        std::memcpy(&fv, &v, sizeof fv);
        std::memcpy(&fe, &e, sizeof fe);
        p.val.push_back(fv);
        if (has_se) p.se.push_back(fe);
    }
    p.index.resize(val.size());
    for (std::size_t k = 0; k < val.size(); ++k)
        p.index[k] = static_cast<std::uint16_t>(rank[first[k]]);
    return p;
}

// F's entries are stored in segments of this many rows, each inflated alone by the page when
// one of its rows is first asked for (a click), so that the page reads only what it shows.
constexpr std::size_t kRowsPerSegment = 8;

std::vector<float> to_f32(const std::vector<double>& v) { return {v.begin(), v.end()}; }

// Row i of F as (j, F_ij, se_ij) entries (its nonzeros), for a dense or a sparse matrix.
struct DenseSource {
    const FormFactors& ff;
    std::size_t size() const { return ff.size(); }
    bool standard_errors() const { return ff.standard_error.has_value(); }
    template <class Visit>
    void row(std::size_t i, Visit&& visit) const {
        const auto r = static_cast<Eigen::Index>(i);
        const double* F = ff.F.row(r).data();
        const double* se = ff.standard_error ? ff.standard_error->row(r).data() : nullptr;
        const auto n = static_cast<std::size_t>(ff.F.cols());
        for (std::size_t j = 0; j < n; ++j)
            if (F[j] != 0.0) visit(j, F[j], se ? se[j] : 0.0);
    }
};

struct CsrSource {
    const SparseFormFactors& sp;
    std::size_t size() const { return sp.n; }
    bool standard_errors() const { return sp.standard_error.has_value(); }
    template <class Visit>
    void row(std::size_t i, Visit&& visit) const {
        for (auto k = static_cast<std::size_t>(sp.indptr[i]);
             k < static_cast<std::size_t>(sp.indptr[i + 1]); ++k)
            visit(static_cast<std::size_t>(sp.indices[k]), sp.values[k],
                  sp.standard_error ? (*sp.standard_error)[k] : 0.0);
    }
};

// The bin of a positive value: the top 16 bits of its float32 (exponent and 7 bits of
// mantissa), which order positive floats as their values do: 128 bins per octave.
std::uint32_t float_bin(double v) {
    const float f = static_cast<float>(v);
    std::uint32_t bits = 0;
    std::memcpy(&bits, &f, sizeof bits);
    return bits >> 16;
}
double bin_upper_edge(std::uint32_t bin) {
    const std::uint32_t bits = (bin + 1) << 16;
    float f = 0.0f;
    std::memcpy(&f, &bits, sizeof f);
    return f;
}

// The smallest threshold t on the bin edges (128 a factor of two) that keeps at most `budget`
// entries F_ij > t; 0 when every positive entry fits. One pass over F with a histogram.
template <class Rows>
double auto_threshold(const Rows& m, std::size_t budget) {
    std::vector<std::size_t> bins(1u << 15, 0);
    std::size_t positive = 0;
    for (std::size_t i = 0; i < m.size(); ++i)
        m.row(i, [&](std::size_t, double v, double) {
            if (!(v > 0.0)) return;
            ++positive;
            ++bins[std::min<std::size_t>(float_bin(v), bins.size() - 1)];
        });
    if (positive <= budget) return 0.0;
    // Keep the bins above the first one (from the top) that would not fit: its upper edge.
    std::size_t above = 0;
    for (std::size_t b = bins.size(); b-- > 0;) {
        if (above + bins[b] > budget) return bin_upper_edge(static_cast<std::uint32_t>(b));
        above += bins[b];
    }
    return 0.0;
}

// The method's bound on |F_ij − exact| per entry, from the run's report (exact-grade methods).
std::optional<double> error_bound_per_entry(const nlohmann::json& report) {
    if (!report.is_object() || !report.contains("details")) return std::nullopt;
    const nlohmann::json& d = report["details"];
    if (!d.is_object() || !d.contains("error_bound_per_entry")) return std::nullopt;
    const nlohmann::json& e = d["error_bound_per_entry"];
    if (!e.is_number() || !(e.get<double>() >= 0.0)) return std::nullopt;
    return e.get<double>();
}

template <class Rows>
nlohmann::json matrix_json(const Scene& scene, const Rows& m, const PageOptions& options,
                           std::optional<double> bound_per_entry, nlohmann::json& fields) {
    const std::size_t n = m.size();
    if (n != scene.patches.size())
        throw Error(fmt::format("the page's matrix is {}×{} but the scene has {} patches", n, n,
                                scene.patches.size()));
    const double threshold =
        options.threshold >= 0.0 ? options.threshold : auto_threshold(m, options.max_entries);
    std::vector<std::uint32_t> row_ptr{0}, col;
    std::vector<float> val, se, dropped(n, 0.0f), se_max(n, 0.0f), row_error(n, 0.0f);
    std::vector<double> row_sum(n, 0.0);
    std::size_t nonzeros = 0;
    // The share of each row's mass left out, for the page's statement of what it stores.
    double share_sum = 0.0, share_max = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        double sum = 0.0, lost = 0.0, worst = 0.0, variance = 0.0;
        std::size_t entries = 0;
        m.row(i, [&](std::size_t j, double v, double e) {
            ++nonzeros;
            ++entries;
            sum += v;
            worst = std::max(worst, e);
            variance += e * e;
            if (v > threshold || v < 0.0) {
                col.push_back(static_cast<std::uint32_t>(j));
                val.push_back(static_cast<float>(v));
                if (m.standard_errors()) se.push_back(static_cast<float>(e));
            } else {
                lost += v;
            }
        });
        row_sum[i] = sum;
        dropped[i] = static_cast<float>(lost);
        const double share = sum > 0.0 ? lost / sum : 0.0;
        share_sum += share;
        share_max = std::max(share_max, share);
        se_max[i] = static_cast<float>(worst);
        // The row sum's error: entries × the bound per entry, or 3 standard errors of the sum
        // (entries treated as independent, as the report's row_sum_standard_error_max).
        row_error[i] = static_cast<float>(bound_per_entry ? double(entries) * *bound_per_entry
                                                          : 3.0 * std::sqrt(variance));
        row_ptr.push_back(static_cast<std::uint32_t>(col.size()));
    }
    std::vector<std::size_t> segments;
    for (std::size_t i = 0; i < n; i += kRowsPerSegment) segments.push_back(row_ptr[i]);
    segments.push_back(val.size());
    nlohmann::json j = {{"threshold", threshold},
                        {"rows_per_segment", kRowsPerSegment},
                        {"stored_entries", val.size()},
                        {"nonzeros", nonzeros},
                        {"dropped_share_mean", n > 0 ? share_sum / double(n) : 0.0},
                        {"dropped_share_max", share_max},
                        {"row_ptr", u32(row_ptr)},
                        {"col", row_delta_indices(row_ptr, col, n, segments)},
                        {"col_coding", "row-delta"},
                        {"dropped", f32(dropped)},
                        {"row_sum", f64(row_sum)}};
    if (const std::optional<Palette> p = palette_of(val, se)) {
        j["palette"] = {{"val", f32(p->val)}};
        if (m.standard_errors()) j["palette"]["standard_error"] = f32(p->se);
        j["entry_index"] = typed(p->index, "u16", Bytes::planes, &segments);
    } else {
        j["val"] = f32(val, Bytes::planes, &segments);
        if (m.standard_errors()) j["standard_error"] = f32(se, Bytes::as_is, &segments);
    }
    std::vector<float> sky(n);
    for (std::size_t i = 0; i < n; ++i)
        sky[i] = static_cast<float>(std::max(0.0, 1.0 - row_sum[i]));
    fields.push_back({{"key", "row_sum"},
                      {"label", "row sum Σ_j F_ij"},
                      {"unit", ""},
                      {"values", f32(to_f32(row_sum))}});
    fields.push_back({{"key", "sky_factor"},
                      {"label", "sky factor 1 − Σ_j F_ij (what escapes)"},
                      {"unit", ""},
                      {"values", f32(sky)}});
    if (m.standard_errors())
        fields.push_back({{"key", "standard_error"},
                          {"label", "standard error, largest of the row"},
                          {"unit", ""},
                          {"values", f32(se_max)}});
    if (bound_per_entry)
        fields.push_back({{"key", "error_bound"},
                          {"label", fmt::format("error bound of the row sum: its nonzero entries "
                                                "× the method's bound per entry {:.3g}",
                                                *bound_per_entry)},
                          {"unit", "dimensionless, as F"},
                          {"values", f32(row_error)}});
    else if (m.standard_errors())
        fields.push_back(
            {{"key", "error_bound"},
             {"label", "error bound of the row sum: 3 standard errors, 3 √(Σ_j se_ij²)"},
             {"unit", "dimensionless, as F"},
             {"values", f32(row_error)}});
    return j;
}

void check_size(const Scene& scene, std::size_t size, const char* what) {
    if (size != 0 && size != scene.patches.size())
        throw Error(fmt::format("the page's {} has {} values but the scene has {} patches", what,
                                size, scene.patches.size()));
}

nlohmann::json scalar_field(const char* key, const char* label, const char* unit,
                            const std::vector<double>& v) {
    return {{"key", key}, {"label", label}, {"unit", unit}, {"values", f32(to_f32(v))}};
}

// JSON for a <script type="application/json"> element: nothing in it can close the element or
// open a comment, since '<', '>' and '&' only occur inside JSON strings and are escaped there.
std::string script_safe_json(const nlohmann::json& j) {
    const std::string text = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    std::string out;
    out.reserve(text.size() + text.size() / 64);
    for (char c : text) {
        switch (c) {
            case '<':
                out += "\\u003c";
                break;
            case '>':
                out += "\\u003e";
                break;
            case '&':
                out += "\\u0026";
                break;
            default:
                out += c;
        }
    }
    return out;
}

}  // namespace

nlohmann::json page_data(const Scene& scene, const PageContent& content,
                         const PageOptions& options) {
    if (content.form_factors && content.sparse)
        throw Error("a page shows one matrix: give the dense or the sparse one, not both");
    const std::size_t n = scene.patches.size();
    check_size(scene, content.radiosity.size(), "radiosity");
    check_size(scene, content.temperature.size(), "temperature");
    check_size(scene, content.net_flux.size(), "net flux");
    check_size(scene, content.thermal_radiosity.size(), "radiosity J");

    // Patches: areas, surfaces, polygons and their triangulation (indices into the vertices).
    std::vector<double> area(n);
    std::vector<std::uint32_t> surface(n), vertex_offset{0}, triangles, triangle_patch;
    std::vector<float> vertices;
    for (std::size_t i = 0; i < n; ++i) {
        const Patch& p = scene.patches[i];
        area[i] = p.area;
        surface[i] = static_cast<std::uint32_t>(std::max(p.surface, 0));
        const std::uint32_t base = vertex_offset.back();
        for (const Vec3& v : p.polygon.vertices)
            for (int c = 0; c < 3; ++c) vertices.push_back(static_cast<float>(v[c]));
        for (const auto& t : triangulate(p.polygon)) {
            for (int c = 0; c < 3; ++c)
                triangles.push_back(base + static_cast<std::uint32_t>(t[c]));
            triangle_patch.push_back(static_cast<std::uint32_t>(i));
        }
        vertex_offset.push_back(base + static_cast<std::uint32_t>(p.polygon.size()));
    }
    nlohmann::json surfaces = nlohmann::json::array();
    for (const Surface& s : scene.surfaces)
        surfaces.push_back({{"name", s.name}, {"obstruction", s.obstruction}});

    nlohmann::json fields = nlohmann::json::array();
    if (!content.radiosity.empty()) {
        double exposure = content.exposure;
        if (!(exposure > 0.0)) {
            const double q =
                detail::patch_luminance_quantile(scene, content.radiosity, content.emitters, 0.99);
            exposure = q > 0.0 ? 0.9 / q : 1.0;
        }
        std::vector<float> rgb;
        rgb.reserve(3 * n);
        for (const Rgb& c : content.radiosity)
            for (int k = 0; k < 3; ++k) rgb.push_back(static_cast<float>(c[k]));
        fields.push_back({{"key", "radiosity"},
                          {"label", "radiosity B"},
                          {"unit", ""},
                          {"kind", "rgb"},
                          {"exposure", exposure},
                          {"values", f32(rgb)}});
    }
    if (!content.temperature.empty())
        fields.push_back(scalar_field("temperature", "temperature", "K", content.temperature));
    if (!content.net_flux.empty())
        fields.push_back(
            scalar_field("net_flux", "net flux q (+ leaves)", "W/m²", content.net_flux));
    if (!content.thermal_radiosity.empty())
        fields.push_back(
            scalar_field("radiosity_j", "radiosity J", "W/m²", content.thermal_radiosity));
    {
        // The materials' colours (reflectance; emitters white), for a page without a solution.
        std::vector<float> rgb;
        rgb.reserve(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
            const Material& m = scene.material_of(i);
            const bool emits = m.emission.maxCoeff() > 0.0;
            for (int k = 0; k < 3; ++k)
                rgb.push_back(emits ? 1.0f : static_cast<float>(m.reflectance[k]));
        }
        fields.push_back({{"key", "material"},
                          {"label", "material colour (reflectance)"},
                          {"unit", ""},
                          {"kind", "rgb"},
                          {"exposure", 1.0},
                          {"values", f32(rgb)}});
    }

    const Camera cam = scene.camera ? *scene.camera : auto_camera(scene, 1.0);
    nlohmann::json j = {
        {"format", "formfactor-page"},
        {"version", 2},
        {"title", !content.title.empty() ? content.title
                  : !scene.title.empty() ? scene.title
                                         : scene.name},
        {"scene", {{"name", scene.name}, {"title", scene.title}}},
        {"camera",
         {{"eye", {cam.eye.x(), cam.eye.y(), cam.eye.z()}},
          {"target", {cam.target.x(), cam.target.y(), cam.target.z()}},
          {"up", {cam.up.x(), cam.up.y(), cam.up.z()}},
          {"fov", cam.fov_degrees}}},
        {"surfaces", surfaces},
        {"patches",
         {{"count", n},
          {"area", f64(area)},
          {"surface", u32(surface)},
          {"vertex_offset", u32(vertex_offset)},
          {"vertices", f32(vertices, Bytes::as_is)},
          {"triangles", u32(triangles)},
          {"triangle_patch", u32(triangle_patch)}}},
    };
    const std::optional<double> bound = error_bound_per_entry(content.report);
    if (content.form_factors)
        j["matrix"] =
            matrix_json(scene, DenseSource{*content.form_factors}, options, bound, fields);
    else if (content.sparse)
        j["matrix"] = matrix_json(scene, CsrSource{*content.sparse}, options, bound, fields);
    j["fields"] = fields;
    if (!content.report.is_null()) j["report"] = content.report;
    return j;
}

std::string page_html(const Scene& scene, const PageContent& content, const PageOptions& options) {
    nlohmann::json j = page_data(scene, content, options);
    // F's entries (most of the file) go in a second block after the script, so that the browser
    // runs the script and draws the scene before it has read them; the page finds them by the
    // block's id.
    nlohmann::json entries = nlohmann::json::object();
    const bool has_matrix = j.contains("matrix");
    if (has_matrix) {
        nlohmann::json& m = j["matrix"];
        for (const char* key : {"col", "val", "standard_error", "entry_index"})
            if (m.contains(key)) {
                entries[key] = std::move(m[key]);
                m.erase(key);
            }
        m["entries_block"] = "ff-matrix";
    }
    const std::string data = script_safe_json(j);
    j = nullptr;
    const std::string matrix = script_safe_json(entries);
    entries = nullptr;
    std::string html;
    html.reserve(data.size() + matrix.size() + std::strlen(detail::kPageScript) + 4096);
    html += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
    // Every request is forbidden; only the inlined script and style (by hash) run.
    html += fmt::format(
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
        "script-src '{}'; style-src '{}'; img-src 'none'; connect-src 'none'; font-src 'none'; "
        "media-src 'none'; object-src 'none'; worker-src 'none'; frame-src 'none'; "
        "base-uri 'none'; form-action 'none'\">\n",
        detail::kPageScriptHash, detail::kPageStyleHash);
    html += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
    html += "<meta name=\"generator\" content=\"formfactor " FF_VERSION "\">\n";
    html += "<title>formfactor result</title>\n<style>";
    html += detail::kPageStyle;
    html += "</style>\n</head>\n<body>\n<div id=\"ff-app\"></div>\n";
    html += "<script type=\"application/json\" id=\"ff-data\">";
    html += data;
    html += "</script>\n<script>";
    html += detail::kPageScript;
    html += "</script>\n";
    if (has_matrix) {
        html += "<script type=\"application/json\" id=\"ff-matrix\">";
        html += matrix;
        html += "</script>\n";
    }
    html += "</body>\n</html>\n";
    return html;
}

void write_page(const std::string& path, const Scene& scene, const PageContent& content,
                const PageOptions& options) {
    const std::string html = page_html(scene, content, options);
    write_file_atomically(path, [&](std::ostream& out) { out << html; });
}

}  // namespace formfactor
