#pragma once
// The page's script and style sheet, bundled from web/ at build time (web/tools/build.mjs
// generates page_bundle.cpp in the build tree), with the CSP hashes ('sha256-…') that let the
// page run exactly them.

namespace formfactor::detail {

extern const char* const kPageScript;
extern const char* const kPageStyle;
extern const char* const kPageScriptHash;
extern const char* const kPageStyleHash;

}  // namespace formfactor::detail
