// fork, pipe and waitpid. The child writes one status byte, then either the result or an error's
// subject, reason and exit code, each length-prefixed; it leaves with _exit so that nothing of the
// parent (stdio buffers, atexit handlers) runs twice.
#include "tritrace/scene/io/isolated_call.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <new>

#include "tritrace/error.h"

namespace tritrace {
namespace {

enum Status : uint8_t { kResult = 1, kError = 2, kOutOfMemory = 3, kOtherException = 4 };

bool write_all(int fd, const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

bool write_blob(int fd, const void* data, uint64_t size) {
  return write_all(fd, &size, sizeof(size)) && write_all(fd, data, size);
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

[[noreturn]] void child(int fd, const std::function<std::vector<uint8_t>()>& work,
                        uint64_t memory_limit) {
  // Sanitizers reserve terabytes of address space for their shadow memory, so an address-space
  // limit would fail every allocation; sanitized builds run without it.
  if (!kSanitized) {
    const rlimit limit{memory_limit, memory_limit};
    ::setrlimit(RLIMIT_AS, &limit);
  }
  bool ok = true;
  try {
    const std::vector<uint8_t> result = work();
    const uint8_t status = kResult;
    ok = write_all(fd, &status, 1) && write_blob(fd, result.data(), result.size());
  } catch (const Error& e) {
    const uint8_t status = kError;
    const int32_t code = static_cast<int32_t>(e.exit_code());
    ok = write_all(fd, &status, 1) && write_blob(fd, e.subject().data(), e.subject().size()) &&
         write_blob(fd, e.reason().data(), e.reason().size()) && write_all(fd, &code, sizeof(code));
  } catch (const std::bad_alloc&) {
    const uint8_t status = kOutOfMemory;
    ok = write_all(fd, &status, 1);
  } catch (...) {
    const uint8_t status = kOtherException;
    ok = write_all(fd, &status, 1);
  }
  ::close(fd);
  ::_exit(ok ? 0 : 1);
}

class Reader {
 public:
  explicit Reader(const std::vector<uint8_t>& bytes) : bytes_(bytes) {}
  bool take(void* out, size_t n) {
    if (bytes_.size() - pos_ < n) return false;
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  bool blob(std::vector<uint8_t>& out) {
    uint64_t n = 0;
    if (!take(&n, sizeof(n)) || bytes_.size() - pos_ < n) return false;
    out.assign(bytes_.begin() + static_cast<ptrdiff_t>(pos_),
               bytes_.begin() + static_cast<ptrdiff_t>(pos_ + n));
    pos_ += n;
    return true;
  }

 private:
  const std::vector<uint8_t>& bytes_;
  size_t pos_ = 0;
};

}  // namespace

std::vector<uint8_t> call_isolated(const std::string& subject,
                                   const std::function<std::vector<uint8_t>()>& work,
                                   uint64_t memory_limit_bytes) {
  int fds[2];
  if (::pipe(fds) != 0)
    throw Error(subject, std::string("cannot create a pipe: ") + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(subject, std::string("cannot start the importer process: ") + std::strerror(err));
  }
  if (pid == 0) {
    ::close(fds[0]);
    child(fds[1], work, memory_limit_bytes);
  }
  ::close(fds[1]);
  std::vector<uint8_t> bytes;
  uint8_t buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.insert(bytes.end(), buffer, buffer + n);
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    throw Error(subject, std::string("cannot import: the importer crashed (") +
                             strsignal(WTERMSIG(status)) + ")");
  }
  Reader in(bytes);
  uint8_t kind = 0;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !in.take(&kind, 1)) {
    throw Error(subject, "cannot import: the importer process failed");
  }
  std::vector<uint8_t> result;
  switch (kind) {
    case kResult:
      if (!in.blob(result)) break;
      return result;
    case kError: {
      std::vector<uint8_t> who, why;
      int32_t code = 1;
      if (!in.blob(who) || !in.blob(why) || !in.take(&code, sizeof(code))) break;
      throw Error(std::string(who.begin(), who.end()), std::string(why.begin(), why.end()),
                  code == 2 ? ExitCode::kUsage : ExitCode::kRuntime);
    }
    case kOutOfMemory:
      throw Error(subject, "cannot import: out of memory");
    default:
      break;
  }
  throw Error(subject, "cannot import: the importer failed");
}

}  // namespace tritrace
