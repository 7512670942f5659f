#pragma once
// The check of a binary glTF file that comes before Open Asset Import reads it
// (src/scene/glb_check.cpp).

#include <string>

namespace formfactor::detail {

/// When the file at `path` starts with binary glTF's magic `glTF`, checks that the sizes its
/// header declares fit in the file, and throws InputError(path, 0, ...) when they do not:
/// version 1 (KHR_binary_glTF): the 20-byte header and the scene of `contentLength` bytes;
/// version 2 (GLB): the total `length` and every chunk's `chunkLength` with its 8-byte header.
/// Any other content is left to Open Asset Import.
///
/// Open Asset Import 5.2.5 allocates the declared scene before it reads it: a version-1 header
/// declaring 1.85 GB of scene in a file of 34 bytes asks for 1.85 GB.
void check_glb(const std::string& path);

}  // namespace formfactor::detail
