// libFuzzer target: pbrt-v4 scene files (see fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  tritrace::fuzz::pbrt_scene_one_input(data, size);
  return 0;
}
