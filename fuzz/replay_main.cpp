// Replays saved fuzzer inputs through the same entry points, in the normal build and under ctest:
// `tritrace_fuzz_replay scene_json|mesh_memory|partial_film FILE_OR_FOLDER...`. Passing means no
// crash.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_entries.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s scene_json|mesh_memory|partial_film FILE_OR_FOLDER...\n",
                 argv[0]);
    return 2;
  }
  const bool scene = std::strcmp(argv[1], "scene_json") == 0;
  const bool part = std::strcmp(argv[1], "partial_film") == 0;
  if (!scene && !part && std::strcmp(argv[1], "mesh_memory") != 0) {
    std::fprintf(stderr, "unknown target '%s'\n", argv[1]);
    return 2;
  }
  std::vector<fs::path> files;
  for (int i = 2; i < argc; ++i) {
    if (fs::is_directory(argv[i])) {
      for (const auto& e : fs::directory_iterator(argv[i])) {
        if (e.is_regular_file()) files.push_back(e.path());
      }
    } else {
      files.emplace_back(argv[i]);
    }
  }
  for (const fs::path& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
    if (scene) {
      tritrace::fuzz::scene_json_one_input(data, bytes.size());
    } else if (part) {
      tritrace::fuzz::partial_film_one_input(data, bytes.size());
    } else {
      tritrace::fuzz::mesh_memory_one_input(data, bytes.size(), /*isolate_assimp=*/true);
    }
  }
  std::printf("replayed %zu inputs\n", files.size());
  return files.empty() ? 1 : 0;
}
