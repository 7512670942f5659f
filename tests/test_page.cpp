// The result page's writer (formfactor/output/page.h) and `formfactor view`: the data block
// stays data whatever the names, the stored rows and their threshold, and the CLI's errors.
// The page itself is checked in headless Chromium (web/test/browser/).

#include <doctest/doctest.h>
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/output/matrix_io.h"
#include "formfactor/output/page.h"
#include "formfactor/scene/scene.h"
#include "support/cli_runner.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::Cli;
using formfactor::testing::CliResult;

namespace {

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

constexpr const char* kAlphabet =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// The bytes of a page array ({dtype, count, compression, base64}), inflated when deflated and
/// put back in order when stored by byte planes.
std::string decode_bytes(const nlohmann::json& entry) {
    const std::string b64 = entry["base64"];
    std::string bytes;
    int bits = 0;
    std::uint32_t acc = 0;
    for (char c : b64) {
        const char* at = std::strchr(kAlphabet, c);
        if (c == '=' || !at) break;
        acc = (acc << 6) | static_cast<std::uint32_t>(at - kAlphabet);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            bytes += static_cast<char>((acc >> bits) & 0xff);
        }
    }
    if (entry.value("compression", "") != "deflate") return bytes;
    const std::size_t size_of = entry["dtype"] == "f64" ? 8 : entry["dtype"] == "u16" ? 2 : 4;
    uLongf size = entry["count"].get<std::size_t>() * size_of;
    std::string out(size, '\0');
    REQUIRE(uncompress(reinterpret_cast<Bytef*>(out.data()), &size,
                       reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()) == Z_OK);
    REQUIRE(size == out.size());
    if (!entry.value("byte_planes", false)) return out;
    // Byte planes within each segment (the whole array: one segment).
    std::vector<std::size_t> bounds{0, entry["count"].get<std::size_t>()};
    if (entry.contains("segments")) bounds = entry["segments"].get<std::vector<std::size_t>>();
    std::string values(out.size(), '\0');
    for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
        const std::size_t a = bounds[s], n = bounds[s + 1] - a;
        for (std::size_t k = 0; k < n; ++k)
            for (std::size_t b = 0; b < size_of; ++b)
                values[(a + k) * size_of + b] = out[a * size_of + b * n + k];
    }
    return values;
}

/// The values of a page array of type T.
template <class T>
std::vector<T> decode(const nlohmann::json& entry) {
    const std::string bytes = decode_bytes(entry);
    std::vector<T> out(bytes.size() / sizeof(T));
    std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
    return out;
}
std::vector<float> decode_f32(const nlohmann::json& entry) { return decode<float>(entry); }

/// The cube (6 patches) with F_ij = 0.2 for j ≠ i, except row 0: 0.5, 0.3, 0.1, 0.06, 0.04.
FormFactors cube_matrix(const Scene& scene) {
    FormFactors ff;
    const auto n = static_cast<Eigen::Index>(scene.patches.size());
    ff.F = DenseMatrix::Constant(n, n, 0.2);
    ff.F.diagonal().setZero();
    ff.F.row(0) << 0.0, 0.5, 0.3, 0.1, 0.06, 0.04;
    for (const Patch& p : scene.patches) ff.areas.push_back(p.area);
    return ff;
}

}  // namespace

TEST_CASE("page: names from input files cannot end the data block or become markup") {
    Scene scene = builtin_scene("cube");
    scene.surfaces[0].name = "</script><script>alert(1)</script>";
    scene.surfaces[1].name = "<img src=x onerror=alert(2)> & <!--";
    scene.surfaces[2].name = std::string("bad utf-8 \xff\xfe");
    const FormFactors ff = cube_matrix(scene);
    PageContent content;
    content.form_factors = &ff;
    content.title = "<b>title</b>";
    const std::string html = page_html(scene, content);
    const auto begin = html.find("<script type=\"application/json\" id=\"ff-data\">");
    REQUIRE(begin != std::string::npos);
    const auto body = begin + std::strlen("<script type=\"application/json\" id=\"ff-data\">");
    const auto end = html.find("</script>", body);
    const std::string data = html.substr(body, end - body);
    CHECK(data.find('<') == std::string::npos);
    CHECK(data.find('>') == std::string::npos);
    CHECK(data.find('&') == std::string::npos);
    // The data block's, the bundle's and that of F's entries.
    CHECK(count(html, "</script>") == 3);
    const nlohmann::json j = nlohmann::json::parse(data);
    CHECK(j["surfaces"][0]["name"] == "</script><script>alert(1)</script>");
    CHECK(j["surfaces"][1]["name"] == "<img src=x onerror=alert(2)> & <!--");
    CHECK(j["title"] == "<b>title</b>");
    CHECK(html.find("default-src 'none'") != std::string::npos);
    CHECK(html.find("'unsafe-inline'") == std::string::npos);
    CHECK(html.find("'unsafe-eval'") == std::string::npos);
}

TEST_CASE("page: rows keep the entries above the threshold, and each row's dropped mass") {
    const Scene scene = builtin_scene("cube");
    const FormFactors ff = cube_matrix(scene);
    PageContent content;
    content.form_factors = &ff;
    PageOptions options;
    options.threshold = 0.08;
    nlohmann::json m = page_data(scene, content, options)["matrix"];
    CHECK(m["nonzeros"] == 30);
    CHECK(m["stored_entries"] == 3 + 25);
    const auto dropped = decode_f32(m["dropped"]);
    REQUIRE(dropped.size() == 6);
    CHECK(dropped[0] == doctest::Approx(0.1));
    CHECK(dropped[1] == 0.0f);
    // The page states the share of a row's mass dropped: the mean and the largest over the rows.
    const auto row_sum = decode<double>(m["row_sum"]);
    double share_sum = 0.0, share_max = 0.0;
    for (std::size_t i = 0; i < 6; ++i) {
        share_sum += dropped[i] / row_sum[i];
        share_max = std::max(share_max, dropped[i] / row_sum[i]);
    }
    CHECK(share_max > 0.0);
    CHECK(m["dropped_share_max"].get<double>() == doctest::Approx(share_max).epsilon(1e-6));
    CHECK(m["dropped_share_mean"].get<double>() == doctest::Approx(share_sum / 6).epsilon(1e-6));
    // Every array is deflated; row 0 keeps 0.5, 0.3, 0.1 (columns 1, 2, 3: steps 1, 1, 1), row 1
    // keeps columns 0, 2, 3, 4, 5 (steps from 0: 0, 2, 1, 1, 1), exactly as float32.
    CHECK(m["col"]["compression"] == "deflate");
    CHECK(m["col_coding"] == "row-delta");
    const auto ptr = decode<std::uint32_t>(m["row_ptr"]);
    const auto col = decode<std::uint16_t>(m["col"]);
    const auto val = decode_f32(m["val"]);
    REQUIRE(ptr.size() == 7);
    REQUIRE(col.size() == 28);
    REQUIRE(val.size() == 28);
    CHECK(ptr[1] == 3);
    CHECK(std::vector<std::uint16_t>(col.begin(), col.begin() + 8) ==
          std::vector<std::uint16_t>{1, 1, 1, 0, 2, 1, 1, 1});
    CHECK(std::vector<float>(val.begin(), val.begin() + 4) ==
          std::vector<float>{0.5f, 0.3f, 0.1f, 0.2f});
    // A budget of entries picks the smallest threshold that fits: the 25 entries of 0.2 in
    // rows 1..5 and row 0's 0.5 and 0.3 are the 27 largest.
    options = {};
    options.max_entries = 27;
    m = page_data(scene, content, options)["matrix"];
    CHECK(m["stored_entries"] == 27);
    CHECK(m["threshold"].get<double>() >= 0.1);
    CHECK(m["threshold"].get<double>() < 0.2);
    options.max_entries = 30;
    CHECK(page_data(scene, content, options)["matrix"]["threshold"] == 0.0);
    CHECK(page_data(scene, content, options)["matrix"]["dropped_share_max"] == 0.0);
    // Each array is deflated once, its bytes laid out by what it holds: F's values and the
    // indices by byte planes, the vertex coordinates as they are.
    const nlohmann::json d = page_data(scene, content, {});
    CHECK(d["matrix"]["val"].value("byte_planes", false));
    CHECK(d["matrix"]["row_ptr"].value("byte_planes", false));
    CHECK(d["patches"]["triangles"].value("byte_planes", false));
    CHECK_FALSE(d["patches"]["vertices"].value("byte_planes", false));
}

TEST_CASE("page: entries with few distinct (value, standard error) pairs are stored by a palette") {
    // 726 patches, 525,625 entries taking 40 values (as Monte-Carlo hit counts do), each with its
    // standard error: stored as the index of its pair, in segments of rows; rows 8 to 15 (the
    // second segment) are empty.
    Scene scene = builtin_scene("cube");
    SubdivisionOptions sub;
    sub.n = 11;
    subdivide(scene, sub);
    const auto n = static_cast<Eigen::Index>(scene.patches.size());
    REQUIRE(n == 726);
    FormFactors ff;
    ff.F = DenseMatrix::Zero(n, n);
    DenseMatrix se = DenseMatrix::Zero(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = 0; j < n; ++j)
            if (i != j && (i < 8 || i >= 16)) {
                ff.F(i, j) = double((i * 7 + j * 13) % 40 + 1) / 64.0;
                se(i, j) = ff.F(i, j) / 10.0;
            }
    ff.standard_error = se;
    for (const Patch& p : scene.patches) ff.areas.push_back(p.area);
    PageContent content;
    content.form_factors = &ff;
    const nlohmann::json m = page_data(scene, content)["matrix"];
    REQUIRE(m.contains("palette"));
    CHECK_FALSE(m.contains("val"));
    CHECK_FALSE(m.contains("standard_error"));
    const auto pal_val = decode_f32(m["palette"]["val"]);
    const auto pal_se = decode_f32(m["palette"]["standard_error"]);
    CHECK(pal_val.size() == 40);
    CHECK(pal_se.size() == 40);
    const auto ptr = decode<std::uint32_t>(m["row_ptr"]);
    const auto col = decode<std::uint16_t>(m["col"]);
    const auto index = decode<std::uint16_t>(m["entry_index"]);
    REQUIRE(index.size() == std::size_t((n - 8) * (n - 1)));
    const auto segments = m["entry_index"]["segments"].get<std::vector<std::size_t>>();
    REQUIRE(segments.size() == (726 + 7) / 8 + 1);
    CHECK(segments[1] == segments[2]);
    CHECK(m["entry_index"]["segment_bytes"].size() == segments.size());
    std::size_t wrong = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
        std::uint32_t j = 0;
        for (std::uint32_t k = ptr[i]; k < ptr[i + 1]; ++k) {
            j = k == ptr[i] ? col[k] : j + col[k];
            if (pal_val[index[k]] != static_cast<float>(ff.F(i, j)) ||
                pal_se[index[k]] != static_cast<float>(se(i, j)))
                ++wrong;
        }
    }
    CHECK(wrong == 0);
}

TEST_CASE(
    "page: the error-bound field is the row's entries times the bound per entry, or "
    "3 standard errors of the row sum") {
    const Scene scene = builtin_scene("cube");
    FormFactors ff = cube_matrix(scene);
    PageContent content;
    content.form_factors = &ff;
    auto field = [&](const std::string& key) {
        const nlohmann::json data = page_data(scene, content);
        for (const auto& f : data["fields"])
            if (f["key"] == key) return f;
        return nlohmann::json();
    };
    CHECK(field("error_bound").is_null());  // no report, no standard errors: no bound to show
    content.report = {{"details", {{"error_bound_per_entry", 1e-10}}}};
    nlohmann::json f = field("error_bound");
    REQUIRE(f.is_object());
    CHECK(f["unit"] == "dimensionless, as F");
    CHECK(f["label"].get<std::string>().find("1e-10") != std::string::npos);
    std::vector<float> v = decode_f32(f["values"]);
    REQUIRE(v.size() == 6);
    CHECK(v[0] == doctest::Approx(5e-10));  // 5 nonzero entries in every row
    // A Monte-Carlo matrix: 3 √(Σ_j se_ij²), here se = 0.01 on the 5 entries of each row.
    content.report = nullptr;
    ff.standard_error = DenseMatrix::Constant(6, 6, 0.01);
    ff.standard_error->diagonal().setZero();
    f = field("error_bound");
    REQUIRE(f.is_object());
    CHECK(f["label"].get<std::string>().find("3 standard errors") != std::string::npos);
    v = decode_f32(f["values"]);
    CHECK(v[3] == doctest::Approx(3 * std::sqrt(5 * 1e-4)).epsilon(1e-6));
}

TEST_CASE("page: content that does not match the scene is refused") {
    const Scene scene = builtin_scene("cube");
    PageContent content;
    content.temperature = {300.0, 310.0};
    CHECK_THROWS_AS(page_html(scene, content), Error);
}

TEST_CASE("cli view: one page from a scene, and errors that write nothing") {
    Cli cli;
    CliResult r = cli.run("view cornell --subdivide 2 -o result.html");
    INFO(r.out << r.err);
    REQUIRE(r.code == 0);
    const std::string html = formfactor::testing::read_text(cli.file("result.html"));
    CHECK(html.rfind("<!DOCTYPE html>", 0) == 0);
    CHECK(html.find("\"key\":\"radiosity\"") != std::string::npos);  // cornell has a light
    CHECK(r.out.find("wrote      result.html") != std::string::npos);

    r = cli.run("view cornell -o result.png");
    CHECK(r.code == 2);
    CHECK(r.one_error_line());
    CHECK(!std::filesystem::exists(cli.file("result.png")));

    // A dense F that cannot fit is refused before anything big exists.
    r = cli.run("view cornell --subdivide 2000 -o big.html");
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK(r.err.find("memory") != std::string::npos);
    CHECK(!std::filesystem::exists(cli.file("big.html")));

    write_matrix(cli.file("F.npy"), DenseMatrix::Zero(3, 3));
    r = cli.run("view cornell --subdivide 2 --matrix F.npy -o bad.html");
    CHECK(r.code == 1);
    CHECK(r.one_error_line());
    CHECK(!std::filesystem::exists(cli.file("bad.html")));
}
