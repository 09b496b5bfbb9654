// memfd_create, fork and waitpid. The child writes one status byte, then either the result or an
// error's subject, reason and exit code, each length-prefixed, into the memfd; it leaves with _exit
// so that nothing of the parent (stdio buffers, atexit handlers) runs twice. Once it has exited,
// the parent maps what it wrote.
#include "tritrace/scene/io/isolated_call.h"

#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <new>
#include <span>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/scene/io/load_progress.h"

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

// The result at the start of the memfd: status, size, bytes (the layout write_blob gives).
bool write_result(int fd, const IsolatedOutput& result) {
  const uint64_t total = 1 + sizeof(uint64_t) + result.size;
  if (::ftruncate(fd, static_cast<off_t>(total)) != 0) return false;
  void* mapping = ::mmap(nullptr, total, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (mapping == MAP_FAILED) return false;
  auto* out = static_cast<uint8_t*>(mapping);
  std::memcpy(out + 1, &result.size, sizeof(uint64_t));
  result.write(out + 1 + sizeof(uint64_t));
  out[0] = kResult;  // last: an exception in write() leaves the status to the handler below
  return ::munmap(mapping, total) == 0;
}

[[noreturn]] void child(int fd, const std::function<IsolatedOutput()>& work,
                        uint64_t memory_limit) {
  // Sanitizers reserve terabytes of address space for their shadow memory, so an address-space
  // limit would fail every allocation; sanitized builds run without it.
  if (!kSanitized) {
    const rlimit limit{memory_limit, memory_limit};
    ::setrlimit(RLIMIT_AS, &limit);
  }
  bool ok = true;
  try {
    ok = write_result(fd, work());
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
  explicit Reader(std::span<const uint8_t> bytes) : bytes_(bytes) {}
  bool take(void* out, size_t n) {
    if (bytes_.size() - pos_ < n) return false;
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  // The next length-prefixed blob: its offset and size in the bytes.
  bool blob(size_t& offset, size_t& size) {
    uint64_t n = 0;
    if (!take(&n, sizeof(n)) || bytes_.size() - pos_ < n) return false;
    offset = pos_;
    size = static_cast<size_t>(n);
    pos_ += size;
    return true;
  }
  std::string text(size_t offset, size_t size) const {
    return std::string(reinterpret_cast<const char*>(bytes_.data()) + offset, size);
  }

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

// Closes the memfd and unmaps it on every way out of call_isolated but the result's.
struct Handover {
  int fd = -1;
  const uint8_t* mapping = nullptr;
  size_t size = 0;
  ~Handover() {
    if (mapping != nullptr) ::munmap(const_cast<uint8_t*>(mapping), size);
    if (fd >= 0) ::close(fd);
  }
};

// A LoadProgress in an anonymous shared mapping, followed by `caller` (when there is one) until
// stop_following() or destruction.
class SharedProgress {
 public:
  explicit SharedProgress(LoadProgress* caller) : caller_(caller) {
    if (caller_ == nullptr) return;
    void* page = ::mmap(nullptr, sizeof(LoadProgress), PROT_READ | PROT_WRITE,
                        MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (page == MAP_FAILED) return;  // no progress shown: not a reason to fail the import
    shared_ = new (page) LoadProgress;
    caller_->follow(shared_);
  }
  ~SharedProgress() {
    stop_following();
    if (shared_ != nullptr) {
      shared_->~LoadProgress();
      ::munmap(shared_, sizeof(LoadProgress));
    }
  }
  SharedProgress(const SharedProgress&) = delete;
  SharedProgress& operator=(const SharedProgress&) = delete;

  LoadProgress* shared() const { return shared_; }
  void stop_following() {
    if (caller_ != nullptr && shared_ != nullptr) caller_->follow(nullptr);
  }

 private:
  LoadProgress* caller_;
  LoadProgress* shared_ = nullptr;
};

}  // namespace

IsolatedResult& IsolatedResult::operator=(IsolatedResult&& other) noexcept {
  if (this != &other) {
    if (mapping_ != nullptr) ::munmap(const_cast<uint8_t*>(mapping_), mapping_size_);
    mapping_ = std::exchange(other.mapping_, nullptr);
    mapping_size_ = std::exchange(other.mapping_size_, 0);
    offset_ = std::exchange(other.offset_, 0);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

IsolatedResult::~IsolatedResult() {
  if (mapping_ != nullptr) ::munmap(const_cast<uint8_t*>(mapping_), mapping_size_);
}

IsolatedResult call_isolated(const std::string& subject,
                             const std::function<IsolatedOutput()>& work,
                             uint64_t memory_limit_bytes) {
  // The child reports its progress to a LoadProgress in memory shared with this process, which
  // the caller's progress follows meanwhile (its atomics work across the two processes; the step
  // names are string literals, at the same addresses in both).
  SharedProgress progress(load_progress());
  Handover shared;
  shared.fd = ::memfd_create("tritrace-import", MFD_CLOEXEC);
  if (shared.fd < 0) {
    throw Error(subject, std::string("cannot create shared memory: ") + std::strerror(errno));
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    throw Error(subject, std::string("cannot start the importer process: ") + std::strerror(errno));
  }
  if (pid == 0) {
    const LoadProgressScope report(progress.shared());
    child(shared.fd, work, memory_limit_bytes);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  progress.stop_following();
  if (WIFSIGNALED(status)) {
    throw Error(subject, std::string("cannot import: the importer crashed (") +
                             strsignal(WTERMSIG(status)) + ")");
  }
  struct stat info {};
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || ::fstat(shared.fd, &info) != 0 ||
      info.st_size <= 0) {
    throw Error(subject, "cannot import: the importer process failed");
  }
  shared.size = static_cast<size_t>(info.st_size);
  // MAP_POPULATE: the pages exist already (the child wrote them); map them all at once rather
  // than fault them in one by one while the result is read.
  void* mapping = ::mmap(nullptr, shared.size, PROT_READ, MAP_SHARED | MAP_POPULATE, shared.fd, 0);
  if (mapping == MAP_FAILED) {
    throw Error(subject, std::string("cannot map the importer's result: ") + std::strerror(errno));
  }
  shared.mapping = static_cast<const uint8_t*>(mapping);
  Reader in(std::span(shared.mapping, shared.size));
  uint8_t kind = 0;
  if (!in.take(&kind, 1)) throw Error(subject, "cannot import: the importer process failed");
  size_t offset = 0, size = 0;
  switch (kind) {
    case kResult:
      if (!in.blob(offset, size)) break;
      {
        IsolatedResult result(shared.mapping, shared.size, offset, size);
        shared.mapping = nullptr;  // the result unmaps it
        return result;
      }
    case kError: {
      size_t who_offset = 0, who_size = 0, why_offset = 0, why_size = 0;
      int32_t code = 1;
      if (!in.blob(who_offset, who_size) || !in.blob(why_offset, why_size) ||
          !in.take(&code, sizeof(code))) {
        break;
      }
      throw Error(in.text(who_offset, who_size), in.text(why_offset, why_size),
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
