// Replays saved fuzzer inputs through the same entry points, in the normal build and under ctest:
// `tritrace_fuzz_replay TARGET FILE_OR_FOLDER...`, TARGET one of scene_json, pbrt_scene,
// mesh_memory, hdr_image, exr_image, partial_film. Passing means no crash.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_entries.h"

namespace fs = std::filesystem;

namespace {

void mesh_memory_isolated(const uint8_t* data, size_t size) {
  tritrace::fuzz::mesh_memory_one_input(data, size, /*isolate_assimp=*/true);
}

struct Target {
  const char* name;
  void (*one_input)(const uint8_t*, size_t);
};

constexpr Target kTargets[] = {
    {"scene_json", tritrace::fuzz::scene_json_one_input},
    {"pbrt_scene", tritrace::fuzz::pbrt_scene_one_input},
    {"mesh_memory", mesh_memory_isolated},
    {"hdr_image", tritrace::fuzz::hdr_image_one_input},
    {"exr_image", tritrace::fuzz::exr_image_one_input},
    {"partial_film", tritrace::fuzz::partial_film_one_input},
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s scene_json|pbrt_scene|mesh_memory|hdr_image|exr_image|partial_film "
                 "FILE_OR_FOLDER...\n",
                 argv[0]);
    return 2;
  }
  const Target* target = nullptr;
  for (const Target& t : kTargets) {
    if (std::strcmp(argv[1], t.name) == 0) target = &t;
  }
  if (target == nullptr) {
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
    target->one_input(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replayed %zu inputs\n", files.size());
  return files.empty() ? 1 : 0;
}
