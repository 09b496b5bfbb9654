// write_file_atomic: mkstemp in the target folder, write, fsync, rename.
#include "tritrace/image/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "tritrace/error.h"

namespace tritrace {
namespace {

std::string folder_of(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

std::string errno_text(int err) {
  return std::strerror(err);
}

}  // namespace

void check_writable_path(const std::string& path) {
  if (path.empty()) throw Error("--output", "empty path", ExitCode::kUsage);
  const std::string folder = folder_of(path);
  struct stat st {};
  if (::stat(folder.c_str(), &st) != 0) {
    throw Error(path, "folder '" + folder + "' does not exist");
  }
  if (!S_ISDIR(st.st_mode)) throw Error(path, "'" + folder + "' is not a folder");
  if (::access(folder.c_str(), W_OK) != 0) {
    throw Error(path, "folder '" + folder + "' is not writable");
  }
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    throw Error(path, "is a folder, not a file");
  }
}

void write_file_atomic(const std::string& path, std::span<const uint8_t> bytes) {
  const std::string name = std::filesystem::path(path).filename().string();
  std::string tmp = folder_of(path) + "/." + name + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) throw Error(path, "cannot create a temporary file: " + errno_text(errno));

  auto fail = [&](const std::string& what) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw Error(path, what + ": " + errno_text(err));
  };

  // mkstemp creates the file 0600; an image is an ordinary file, readable by others as the umask
  // allows.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) fail("cannot set permissions");

  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed");
    }
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) fail("fsync failed");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path, "close failed: " + errno_text(err));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error(path, "cannot rename the temporary file into place: " + errno_text(err));
  }
}

}  // namespace tritrace
