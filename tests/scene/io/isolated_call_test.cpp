// call_isolated: what a child process returns through the shared memory arrives byte for byte, and
// every way a child can fail (an Error, a bad_alloc, another exception, a signal) becomes the one
// Error the loaders report.
#include "tritrace/scene/io/isolated_call.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>

#include "tritrace/error.h"

namespace tritrace {
namespace {

constexpr uint64_t kLimit = uint64_t{4} << 30;

// The byte at position i of the test pattern: not periodic over any power of two up to 2^24.
uint8_t pattern(uint64_t i) {
  return static_cast<uint8_t>((i * 2654435761u) >> 13 ^ i >> 24);
}

TEST(IsolatedCall, ReturnsWhatTheChildWroteByteForByte) {
  for (const uint64_t size : {uint64_t{0}, uint64_t{1}, uint64_t{4095}, uint64_t{3} << 20}) {
    const IsolatedResult result = call_isolated(
        "x",
        [size] {
          return IsolatedOutput{size, [size](uint8_t* out) {
                                  for (uint64_t i = 0; i < size; ++i) out[i] = pattern(i);
                                }};
        },
        kLimit);
    ASSERT_EQ(result.bytes().size(), size);
    uint64_t wrong = 0;
    for (uint64_t i = 0; i < size; ++i) wrong += result.bytes()[i] != pattern(i);
    EXPECT_EQ(wrong, 0u) << size << " bytes";
  }
}

TEST(IsolatedCall, ResultsOutliveMovesAndOtherCalls) {
  auto call = [](uint8_t value) {
    return call_isolated(
        "x",
        [value] {
          return IsolatedOutput{16, [value](uint8_t* out) { std::memset(out, value, 16); }};
        },
        kLimit);
  };
  IsolatedResult a = call(7);
  const IsolatedResult b = call(9);
  IsolatedResult moved = std::move(a);
  ASSERT_EQ(moved.bytes().size(), 16u);
  EXPECT_EQ(moved.bytes()[15], 7);
  EXPECT_EQ(b.bytes()[0], 9);
}

// Runs `work` and returns the Error it became (subject: reason), or "" if none.
template <typename Work>
std::string error_of(Work work, ExitCode* code = nullptr) {
  try {
    call_isolated("model.obj", work, kLimit);
  } catch (const Error& e) {
    if (code != nullptr) *code = e.exit_code();
    return e.subject() + ": " + e.reason();
  }
  return "";
}

TEST(IsolatedCall, AnErrorInTheChildComesBackWithItsSubjectReasonAndExitCode) {
  ExitCode code = ExitCode::kRuntime;
  EXPECT_EQ(error_of(
                []() -> IsolatedOutput {
                  throw Error("texture.png", "is missing", ExitCode::kUsage);
                },
                &code),
            "texture.png: is missing");
  EXPECT_EQ(code, ExitCode::kUsage);
  EXPECT_EQ(error_of([]() -> IsolatedOutput { throw Error("a", "b"); }, &code), "a: b");
  EXPECT_EQ(code, ExitCode::kRuntime);
}

TEST(IsolatedCall, AnErrorWhileWritingTheResultComesBackToo) {
  EXPECT_EQ(error_of([] {
              return IsolatedOutput{1 << 20, [](uint8_t*) { throw Error("late", "failure"); }};
            }),
            "late: failure");
}

TEST(IsolatedCall, FailuresOfTheChildBecomeOneError) {
  EXPECT_EQ(error_of([]() -> IsolatedOutput { throw std::bad_alloc(); }),
            "model.obj: cannot import: out of memory");
  EXPECT_EQ(error_of([]() -> IsolatedOutput { throw std::runtime_error("x"); }),
            "model.obj: cannot import: the importer failed");
  // SIGKILL, which no sanitizer intercepts, as a crash stands for any signal.
  const std::string killed = error_of([]() -> IsolatedOutput {
    std::raise(SIGKILL);
    return {};
  });
  EXPECT_EQ(killed.rfind("model.obj: cannot import: the importer crashed (", 0), 0u) << killed;
}

}  // namespace
}  // namespace tritrace
