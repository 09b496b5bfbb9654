// libFuzzer target: partial films, the files `tritrace merge` reads (see fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  tritrace::fuzz::partial_film_one_input(data, size);
  return 0;
}
