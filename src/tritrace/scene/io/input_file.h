// Checks and reads an input file (scene or mesh) with one clear reason per failure: missing, a
// folder, not a regular file, unreadable, empty or too large. Reading only regular files also keeps
// devices such as /dev/zero from hanging a load.
#pragma once

#include <cstddef>
#include <span>
#include <string>

namespace tritrace {

inline constexpr size_t kMaxInputBytes = size_t{1} << 31;  // 2 GiB

// Throws Error(path, reason) unless `path` is a readable, non-empty regular file. Returns its size.
size_t check_input_file(const std::string& path);

// check_input_file, then the whole contents.
std::string read_input_file(const std::string& path);

// A file's bytes mapped read-only (check_input_file's checks and errors first): a mesh reader
// reads the page cache in place, where read_input_file would copy the file into fresh memory
// (190 MB for a 10-million-triangle PLY, each page faulted in). A file truncated by another
// process while mapped makes reading past its new end fault (SIGBUS), as with any mapping.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&& other) noexcept;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::span<const char> bytes() const { return {data_, size_}; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace tritrace
