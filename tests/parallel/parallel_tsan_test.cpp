// ThreadSanitizer sees the synchronisation TBB gives (src/tritrace/parallel.h): a task after its
// hand-over, a wait after its tasks. Built into tritrace_tsan_tests only (`make test-tsan`).
//
// A test that TSan reports a race between two sibling tasks is not here: in every arrangement
// tried (one sibling handed over after the other ended, or both handed over before either wrote,
// ordered only by relaxed flags) TSan reported nothing, with this file's per-task addresses as
// with one global address, because TBB's inline (instrumented) task counting orders the two. The
// first version of such a test passed only because TSan reported a race on the task object
// itself, the read of a member that held the address before the address was acquired.
#include <gtest/gtest.h>

#include "tritrace/parallel.h"

namespace tritrace::parallel {
namespace {

TEST(ParallelTsan, TaskAfterHandOverAndWaitAfterTasksAreNotRaces) {
  // Written before the hand-over, by the task, and after the wait: ordered by TBB, so TSan (which
  // stops `make test-tsan` at its first report) must stay silent.
  int value = 1;
  TaskGroup group;
  group.run([&value] { value += 1; });
  group.wait();
  value += 1;
  EXPECT_EQ(value, 3);
}

}  // namespace
}  // namespace tritrace::parallel
