// Runs a function in a forked child process and brings its result back through memory shared
// with it (a memfd the child writes and this process maps), so that a crash or a runaway
// allocation inside a third-party library (assimp has segfaulted on malformed PLY files found by
// fuzzing) becomes an Error in tritrace instead of taking the process down. The result is not
// copied through a pipe: for a big mesh the pipe's copies into fresh memory cost about as much as
// the import itself (docs/PERFORMANCE.md, "The importer hands its mesh over in shared memory").
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>

namespace tritrace {

// The bytes a child returned, mapped from the memory it wrote them to; unmapped when destroyed.
class IsolatedResult {
 public:
  IsolatedResult() = default;
  IsolatedResult(const uint8_t* mapping, size_t mapping_size, size_t offset, size_t size)
      : mapping_(mapping), mapping_size_(mapping_size), offset_(offset), size_(size) {}
  IsolatedResult(IsolatedResult&& other) noexcept { *this = std::move(other); }
  IsolatedResult& operator=(IsolatedResult&& other) noexcept;
  IsolatedResult(const IsolatedResult&) = delete;
  IsolatedResult& operator=(const IsolatedResult&) = delete;
  ~IsolatedResult();

  std::span<const uint8_t> bytes() const { return {mapping_ + offset_, size_}; }

 private:
  const uint8_t* mapping_ = nullptr;
  size_t mapping_size_ = 0;
  size_t offset_ = 0;
  size_t size_ = 0;
};

// What the function run in the child returns: the size of its result and how to write it, which
// the child then does straight into the shared memory (no copy of the result in the child).
struct IsolatedOutput {
  uint64_t size = 0;
  std::function<void(uint8_t* out)> write;  // writes exactly `size` bytes at `out`
};

// Calls `work` in a child process whose address space is limited to `memory_limit_bytes`, and
// returns the bytes it produced. An Error thrown by `work` is rethrown here as the same Error; a
// child that dies (signal, std::bad_alloc past the limit, abort) becomes
// Error(subject, "cannot import: <what happened>").
IsolatedResult call_isolated(const std::string& subject,
                             const std::function<IsolatedOutput()>& work,
                             uint64_t memory_limit_bytes);

}  // namespace tritrace
