#pragma once
/// The result page: one self-contained HTML file that shows a scene and its form factors in a
/// browser (three.js and the page's script from web/, bundled at build time and inlined with
/// the data; docs/page.md). Nothing is fetched at view time: a Content-Security-Policy in the
/// page forbids every request, and no script is evaluated from data. Names from input files
/// travel as JSON inside <script type="application/json"> with `<`, `>` and `&` written as
/// \u003c, \u003e, \u0026, and the page shows them with textContent.
///
/// Data layout (format "formfactor-page", version 2). The JSON's "patches", "fields" and
/// "matrix" arrays are {dtype, count, compression: "deflate", base64}: little-endian values,
/// deflated in zlib's format (RFC 1950), then base64; with "byte_planes": true the deflated
/// bytes are the values' byte planes (every value's first byte, then every second byte, ...). Patch
/// areas (f64), surfaces (u32), polygon vertices (f32) and their triangulation; colour fields per
/// patch (f32); F as CSR rows keeping F_ij > threshold: row pointers (u32), columns (u16 when N ≤
/// 65,536, else u32; "col_coding": "row-delta": the first column of a row as it is, each next one
/// as the step from the one before), f32 values, f32 standard errors when the method has them, each
/// row's dropped mass (f32) and its exact row sum (f64, over every entry). Values are stored
/// exactly as float32; when the entries (65,536 or more) hold few distinct (value, standard
/// error) pairs (a sixteenth of them at most, as Monte-Carlo hit counts do), "palette" holds the
/// pairs ({val, standard_error}, f32) and "entry_index" (u16) each entry's pair, instead of
/// "val" and "standard_error". F's columns, values and standard errors are stored in segments of
/// "rows_per_segment" rows ("segments": value offsets; "segment_bytes": offsets in the deflated
/// stream, which is fully flushed after each segment; byte planes within each segment), so that
/// the page inflates only the rows it shows; page_html() writes them in a second JSON block
/// (id "ff-matrix", named by the matrix's "entries_block") after the script, which then draws
/// the scene before the browser has read them.

#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/matrix/form_factors.h"
#include "formfactor/matrix/sparse.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// What a page shows beyond the scene's geometry. Every member is optional.
struct PageContent {
    std::string title;  ///< shown as the page's heading; empty = the scene's title or name
    /// F (dense, with its standard errors when it has them) or a sparse F; at most one.
    const FormFactors* form_factors = nullptr;
    const SparseFormFactors* sparse = nullptr;
    /// Radiosity per patch, linear RGB (a radiosity solution), shown in true colour: times
    /// `exposure`, then sRGB, as render_radiosity() does. exposure 0 = automatic (the 99th
    /// area-weighted percentile of the luminance of the non-emitting patches maps to 0.9).
    std::vector<Rgb> radiosity;
    double exposure = 0.0;
    std::vector<bool> emitters;  ///< patches left out of the automatic exposure
    /// A thermal solution per patch: temperature (K), net flux (W/m², + = leaving) and
    /// radiosity J (W/m²).
    std::vector<double> temperature;
    std::vector<double> net_flux;
    std::vector<double> thermal_radiosity;
    /// The run's report (formfactor/output/report.h), shown in a panel; null = none. Its
    /// details.error_bound_per_entry (exact-grade methods) makes the error-bound colour mode the
    /// row's nonzero entries × that bound; without it, a matrix with standard errors gives 3
    /// standard errors of the row sum.
    nlohmann::json report;
};

/// The default of PageOptions::max_entries: every nonzero of a 10,580-patch Monte-Carlo result
/// (13.4 million) is stored.
inline constexpr std::size_t kPageMaxEntries = 16'000'000;

/// The budget of entries of F of a page shown inline, in a notebook's frame (Python's
/// Result._repr_html_): that page is kept in the notebook file, as an attribute of the frame, so
/// it stores at most this many entries (about 0.5 MB of F for a Monte-Carlo result); a page
/// written to a file (to_html, `formfactor view`) keeps kPageMaxEntries.
inline constexpr std::size_t kInlinePageMaxEntries = 200'000;

/// How much of F a page stores.
struct PageOptions {
    /// At most this many entries of F are stored: when F has more nonzeros, the page keeps
    /// F_ij > t for the smallest threshold t (on a grid of 128 steps per factor of two) that fits,
    /// and states t, the share of its mass a row drops (mean and largest) and each row's dropped
    /// mass. The default stores every nonzero of a 10,580-patch Monte-Carlo result (13.4
    /// million): a row's mass lies mostly in its many small entries, so that any threshold drops
    /// much of it (a fifth of a row on average with 8 million entries, half with 1 million).
    std::size_t max_entries = kPageMaxEntries;
    /// ≥ 0: keep exactly the entries F_ij > threshold (max_entries is then ignored).
    double threshold = -1.0;
};

/// The page's HTML. Throws Error when the content does not match the scene (sizes) or both
/// matrices are given.
std::string page_html(const Scene& scene, const PageContent& content,
                      const PageOptions& options = {});

/// The data block alone (the JSON the page reads), for tests and for other viewers.
nlohmann::json page_data(const Scene& scene, const PageContent& content,
                         const PageOptions& options = {});

/// Writes page_html() to `path` atomically. Throws InputError(path, ...) on I/O failure.
void write_page(const std::string& path, const Scene& scene, const PageContent& content,
                const PageOptions& options = {});

}  // namespace formfactor
