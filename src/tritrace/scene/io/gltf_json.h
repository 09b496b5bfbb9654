// The JSON of a glTF 2.0 file: a .gltf's text, or a .glb's first chunk (glTF 2.0, section 4.4
// "Binary glTF"), found without reading the binary chunk. One reader for everything tritrace takes
// from glTF JSON rather than through assimp (materials; the lights and cameras may share it).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace tritrace {

// The JSON text of a glTF file's bytes: the first chunk of a .glb (bytes starting "glTF"), else
// the bytes themselves. Throws Error(subject, reason) for a .glb whose first chunk is not JSON or
// runs past the end.
std::string_view gltf_json_text(std::span<const uint8_t> bytes, const std::string& subject);

// The same from a file, reading only a .glb's header and JSON chunk. Throws Error(path, reason).
std::string read_gltf_json_text(const std::string& path);

}  // namespace tritrace
