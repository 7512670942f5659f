// The binary glTF check before Open Asset Import (see glb_check.h for why).

#include "scene/glb_check.h"

#include <array>
#include <cstdint>
#include <fstream>
#include <string>

#include "formfactor/core/error.h"

namespace formfactor::detail {

namespace {

// The little-endian 32-bit word at b[at].
std::uint64_t word(const std::array<unsigned char, 20>& b, std::size_t at) {
    return std::uint64_t{b[at]} | std::uint64_t{b[at + 1]} << 8 | std::uint64_t{b[at + 2]} << 16 |
           std::uint64_t{b[at + 3]} << 24;
}

}  // namespace

void check_glb(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return;  // the reader says so
    const auto size = static_cast<std::uint64_t>(in.tellg());
    std::array<unsigned char, 20> head{};
    in.seekg(0);
    in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
    const auto got = static_cast<std::uint64_t>(in.gcount());
    if (got < 12 || head[0] != 'g' || head[1] != 'l' || head[2] != 'T' || head[3] != 'F') return;
    auto fail = [&](const std::string& what, std::uint64_t declared) {
        throw InputError(path, 0,
                         "binary glTF: the header declares " + what + " of " +
                             std::to_string(declared) + " bytes, but the file has " +
                             std::to_string(size));
    };
    const std::uint64_t version = word(head, 4);
    if (version == 1) {
        if (got < 20) fail("a header", 20);
        if (word(head, 8) > size) fail("a file", word(head, 8));
        if (20 + word(head, 12) > size) fail("a scene", word(head, 12));
    } else if (version == 2) {
        const std::uint64_t length = word(head, 8);
        if (length > size) fail("a file", length);
        // The chunks: an 8-byte header (chunkLength, chunkType), then chunkLength bytes.
        std::uint64_t at = 12;
        while (at + 8 <= length) {
            std::array<unsigned char, 20> chunk{};
            in.clear();
            in.seekg(static_cast<std::streamoff>(at));
            in.read(reinterpret_cast<char*>(chunk.data()), 8);
            if (in.gcount() < 8) break;
            const std::uint64_t chunk_length = word(chunk, 0);
            if (at + 8 + chunk_length > size) fail("a chunk", chunk_length);
            at += 8 + chunk_length;
        }
    }
}

}  // namespace formfactor::detail
