// A libFuzzer harness for one fuzz target (fuzz_targets.h), chosen at build time.
#include <cstddef>
#include <cstdint>

#include "fuzz_targets.h"

#define TSF_FUZZ_CALL_(name) tsf::fuzz::name
#define TSF_FUZZ_CALL(name) TSF_FUZZ_CALL_(name)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  TSF_FUZZ_CALL(TSF_FUZZ_TARGET)(data, size);
  return 0;
}
