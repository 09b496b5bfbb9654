// Checks and reads an input file (scene or mesh) with one clear reason per failure: missing, a
// folder, not a regular file, unreadable, empty or too large. Reading only regular files also keeps
// devices such as /dev/zero from hanging a load.
#pragma once

#include <cstddef>
#include <string>

namespace tritrace {

inline constexpr size_t kMaxInputBytes = size_t{1} << 31;  // 2 GiB

// Throws Error(path, reason) unless `path` is a readable, non-empty regular file. Returns its size.
size_t check_input_file(const std::string& path);

// check_input_file, then the whole contents.
std::string read_input_file(const std::string& path);

}  // namespace tritrace
