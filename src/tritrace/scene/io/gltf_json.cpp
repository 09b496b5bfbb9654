// Finding a glTF file's JSON: the .glb container's header and first chunk.
#include "tritrace/scene/io/gltf_json.h"

#include <cstring>
#include <fstream>

#include "tritrace/error.h"
#include "tritrace/scene/io/input_file.h"

namespace tritrace {
namespace {

constexpr size_t kGlbHeader = 20;  // magic, version, length, then the first chunk's length, type

uint32_t read_u32_le(const uint8_t* b) {
  return uint32_t{b[0]} | uint32_t{b[1]} << 8 | uint32_t{b[2]} << 16 | uint32_t{b[3]} << 24;
}

bool is_glb(std::span<const uint8_t> header) {
  return header.size() >= kGlbHeader && std::memcmp(header.data(), "glTF", 4) == 0;
}

// The first chunk's length, checked against the `size` bytes of the whole file.
uint32_t json_chunk_length(const uint8_t* header, size_t size, const std::string& subject) {
  const uint32_t chunk = read_u32_le(header + 12);
  if (std::memcmp(header + 16, "JSON", 4) != 0 || chunk > size - kGlbHeader) {
    throw Error(subject, "a .glb whose first chunk is not its JSON");
  }
  return chunk;
}

}  // namespace

std::string_view gltf_json_text(std::span<const uint8_t> bytes, const std::string& subject) {
  const std::string_view all(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (!is_glb(bytes)) return all;
  return all.substr(kGlbHeader, json_chunk_length(bytes.data(), bytes.size(), subject));
}

std::string read_gltf_json_text(const std::string& path) {
  const size_t size = check_input_file(path);
  std::ifstream in(path, std::ios::binary);
  uint8_t header[kGlbHeader];
  if (size >= kGlbHeader && in.read(reinterpret_cast<char*>(header), kGlbHeader) &&
      is_glb(header)) {
    const uint32_t chunk = json_chunk_length(header, size, path);
    std::string json(chunk, '\0');
    if (!in.read(json.data(), chunk)) throw Error(path, "could not read the .glb's JSON chunk");
    return json;
  }
  return read_input_file(path);
}

}  // namespace tritrace
