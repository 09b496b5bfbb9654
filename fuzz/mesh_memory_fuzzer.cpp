// libFuzzer target: mesh files read by assimp from memory (see fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  tritrace::fuzz::mesh_memory_one_input(data, size, /*isolate_assimp=*/false);
  return 0;
}
