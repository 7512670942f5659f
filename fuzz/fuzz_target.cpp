// One libFuzzer target: FF_FUZZ_TARGET names the reader (fuzz/harness.h). CMake builds this file
// once per reader as fuzz_<name>, each linked with the one compiled harness (harness_lib.cpp):
// the harness and the readers' headers are compiled once, not once per target.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace formfactor::fuzz {
bool run_named(std::string_view target, const std::uint8_t* data, std::size_t size);
}  // namespace formfactor::fuzz

#define FF_FUZZ_STRING2(x) #x
#define FF_FUZZ_STRING(x) FF_FUZZ_STRING2(x)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    formfactor::fuzz::run_named(FF_FUZZ_STRING(FF_FUZZ_TARGET), data, size);
    return 0;
}
