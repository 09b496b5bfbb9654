// Input file checks with stat and open, so that each failure gets its own reason.
#include "tritrace/scene/io/input_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/io/load_progress.h"

namespace tritrace {
namespace {

// Opens read-only and checks the file is regular, non-empty and not too large; returns the fd.
int open_checked(const std::string& path, size_t& size) {
  if (path.empty()) throw Error("(empty path)", "no file name given");
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    if (err == ENOENT) throw Error(path, "file not found");
    throw Error(path, std::string("cannot open: ") + std::strerror(err));
  }
  if (S_ISDIR(st.st_mode)) throw Error(path, "is a folder, not a file");
  if (!S_ISREG(st.st_mode)) throw Error(path, "is not a regular file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path, std::string("cannot read: ") + std::strerror(errno));
  if (st.st_size == 0) {
    ::close(fd);
    throw Error(path, "is empty");
  }
  if (static_cast<unsigned long long>(st.st_size) > kMaxInputBytes) {
    ::close(fd);
    throw Error(path, "is larger than 2 GiB");
  }
  size = static_cast<size_t>(st.st_size);
  return fd;
}

}  // namespace

size_t check_input_file(const std::string& path) {
  size_t size = 0;
  ::close(open_checked(path, size));
  return size;
}

std::string read_input_file(const std::string& path) {
  size_t size = 0;
  const int fd = open_checked(path, size);
  std::string bytes(size, '\0');
  progress_begin("reading", size);
  size_t got = 0;
  while (got < size) {
    // In slices, so that a progress display moves while a big file is read.
    constexpr size_t kSlice = size_t{16} << 20;
    const ssize_t n = ::read(fd, bytes.data() + got, std::min(size - got, kSlice));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : 0;
      ::close(fd);
      throw Error(path, err ? std::string("read failed: ") + std::strerror(err)
                            : std::string("file shrank while being read"));
    }
    got += static_cast<size_t>(n);
    progress_advance(static_cast<size_t>(n));
  }
  ::close(fd);
  return bytes;
}

MappedFile::MappedFile(const std::string& path) {
  size_t size = 0;
  const int fd = open_checked(path, size);
  progress_begin("reading", size);
  // MAP_POPULATE maps every page of the page cache in one call, instead of a fault per 64 KiB
  // while the parsers read; where the file is not cached it reads it now, which is the step the
  // progress names.
  void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
  const int err = errno;
  ::close(fd);
  if (p == MAP_FAILED) throw Error(path, std::string("cannot map: ") + std::strerror(err));
  progress_advance(size);
  data_ = static_cast<const char*>(p);
  size_ = size;
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) ::munmap(const_cast<char*>(data_), size_);
}

MappedFile::MappedFile(MappedFile&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) ::munmap(const_cast<char*>(data_), size_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

}  // namespace tritrace
