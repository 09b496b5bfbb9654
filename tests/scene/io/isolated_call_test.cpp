// call_isolated: what a child process returns through the shared memory arrives byte for byte, and
// every way a child can fail (an Error, a bad_alloc, another exception, a signal) becomes the one
// Error the loaders report.
#include "tritrace/scene/io/isolated_call.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>

#include "tritrace/error.h"
#include "tritrace/scene/io/load_progress.h"

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
  EXPECT_EQ(
      error_of(
          []() -> IsolatedOutput { throw Error("texture.png", "is missing", ExitCode::kUsage); },
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

// The child's progress reaches the caller's LoadProgress while the child runs: another thread of
// the caller polls it (as the CLI's phase line does) until it sees the child's step.
TEST(IsolatedCall, TheChildsProgressShowsInTheCallersWhileItRuns) {
  LoadProgress progress;
  std::atomic<bool> seen{false}, finished{false};
  std::thread watcher([&] {
    while (!finished && !seen) {
      seen = progress.describe() == "parsing 50%";
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  {
    const LoadProgressScope report(&progress);
    progress.begin("reading", 0);
    call_isolated(
        "x",
        [] {
          progress_begin("parsing", 10);
          progress_advance(5);
          // A second for the watcher, which polls every 5 ms, to see it.
          std::this_thread::sleep_for(std::chrono::seconds(1));
          return IsolatedOutput{0, [](uint8_t*) {}};
        },
        kLimit);
  }
  finished = true;
  watcher.join();
  EXPECT_TRUE(seen.load());
  EXPECT_EQ(progress.describe(), "reading") << "after the call, the caller's own step again";
}

}  // namespace
}  // namespace tritrace
