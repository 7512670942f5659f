// One libFuzzer target: FF_FUZZ_TARGET names the reader (fuzz/harness.h). CMake builds this file
// once per reader as fuzz_<name>.

#include <cstddef>
#include <cstdint>

#include "fuzz/harness.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    formfactor::fuzz::run(formfactor::fuzz::Target::FF_FUZZ_TARGET, data, size);
    return 0;
}
