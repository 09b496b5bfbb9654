// Runs a function in a forked child process and brings its result back through a pipe, so that a
// crash or a runaway allocation inside a third-party library (assimp has segfaulted on malformed
// PLY files found by fuzzing) becomes an Error in tritrace instead of taking the process down.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace tritrace {

// Calls `work` in a child process whose address space is limited to `memory_limit_bytes`, and
// returns the bytes it produced. An Error thrown by `work` is rethrown here as the same Error; a
// child that dies (signal, std::bad_alloc past the limit, abort) becomes
// Error(subject, "cannot import: <what happened>").
std::vector<uint8_t> call_isolated(const std::string& subject,
                                   const std::function<std::vector<uint8_t>()>& work,
                                   uint64_t memory_limit_bytes);

}  // namespace tritrace
