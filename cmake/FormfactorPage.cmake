# The result page's script (web/): `npm ci` installs the locked packages (three.js, esbuild) into
# the build tree, esbuild bundles web/src, and web/tools/build.mjs writes the bundle into a C++
# source that src/output/page.cpp inlines into every page (the binary needs nothing at run
# time). Sets FF_PAGE_BUNDLE_CPP, FF_NODE and FF_WEB_NODE_MODULES.

find_program(FF_NODE NAMES node nodejs)
find_program(FF_NPM npm)
if(NOT FF_NODE OR NOT FF_NPM)
    message(FATAL_ERROR
        "formfactor's result page (web/) is bundled at build time with node and npm, which were "
        "not found. On Debian: apt-get install nodejs npm (`make deps` does it), then configure "
        "again.")
endif()

set(FF_WEB_BUILD_DIR ${PROJECT_BINARY_DIR}/web)
set(FF_WEB_NODE_MODULES ${FF_WEB_BUILD_DIR}/node_modules)
set(FF_PAGE_BUNDLE_CPP ${FF_WEB_BUILD_DIR}/page_bundle.cpp)
file(MAKE_DIRECTORY ${FF_WEB_BUILD_DIR})
file(GLOB FF_WEB_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/web/src/*)

# npm ci without install scripts: esbuild's binary comes as its platform package.
add_custom_command(
    OUTPUT ${FF_WEB_NODE_MODULES}/.package-lock.json
    COMMAND ${CMAKE_COMMAND} -E copy ${PROJECT_SOURCE_DIR}/web/package.json
            ${PROJECT_SOURCE_DIR}/web/package-lock.json ${FF_WEB_BUILD_DIR}/
    COMMAND ${FF_NPM} ci --ignore-scripts --no-audit --no-fund --loglevel=error
    WORKING_DIRECTORY ${FF_WEB_BUILD_DIR}
    DEPENDS ${PROJECT_SOURCE_DIR}/web/package.json ${PROJECT_SOURCE_DIR}/web/package-lock.json
    COMMENT "npm ci: the result page's packages (web/package-lock.json)"
    VERBATIM)
add_custom_command(
    OUTPUT ${FF_PAGE_BUNDLE_CPP}
    COMMAND ${FF_NODE} ${PROJECT_SOURCE_DIR}/web/tools/build.mjs ${FF_WEB_NODE_MODULES}
            ${FF_PAGE_BUNDLE_CPP}
    DEPENDS ${FF_WEB_NODE_MODULES}/.package-lock.json ${FF_WEB_SOURCES}
            ${PROJECT_SOURCE_DIR}/web/tools/build.mjs
    COMMENT "esbuild: the result page's script bundle"
    VERBATIM)
# The literal is longer than the 65,536 characters C++ promises to every compiler.
set_source_files_properties(${FF_PAGE_BUNDLE_CPP} PROPERTIES COMPILE_OPTIONS -Wno-overlength-strings)
