// Atomic file output: the bytes go to a temporary file in the destination's folder, which is
// flushed and renamed over the destination, so a killed or failed write never leaves a truncated
// file behind.
#pragma once

#include <cstdint>
#include <span>
#include <string>

namespace tritrace {

// Throws Error(path, reason) on failure, after removing the temporary file.
void write_file_atomic(const std::string& path, std::span<const uint8_t> bytes);

// Checks, before any work is done, that `path` could be written: its folder exists, is a folder
// and is writable, and `path` itself is not a folder. Throws Error(path, reason) otherwise.
void check_writable_path(const std::string& path);

}  // namespace tritrace
