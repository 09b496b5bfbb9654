// ThreadSanitizer sees only the synchronisation TBB really gives (src/tritrace/parallel.h): a task
// after its hand-over, a wait after its tasks, and nothing between sibling tasks. Built into
// tritrace_tsan_tests only (`make test-tsan`); elsewhere the test skips.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <cstdlib>

#include "tritrace/parallel.h"

namespace tritrace::parallel {
namespace {

// Written by two sibling tasks with nothing ordering them: a data race.
int shared_value = 0;

// Task A runs on the arena's worker while the caller spins on a relaxed flag (which gives TSan,
// and the C++ memory model, no ordering). Once A has finished, the caller hands over task B and
// waits, which runs B on the caller (or, now and then, on the worker, where program order hides
// the race; hence several rounds). B starts after A ended, so one global hand-over address would
// order it after A and hide the race; with per-task addresses TSan reports it.
void sibling_tasks_write_one_variable() {
  tbb::task_arena arena(2);
  arena.execute([] {
    for (int round = 0; round < 50; ++round) {
      std::atomic<bool> a_done{false};
      TaskGroup group;
      group.run([&a_done] {
        shared_value = 1;
        a_done.store(true, std::memory_order_relaxed);
      });
      while (!a_done.load(std::memory_order_relaxed)) {
      }
      group.run([] { shared_value = 2; });
      group.wait();
    }
  });
}

TEST(ParallelTsan, RaceBetweenSiblingTasksIsReported) {
#ifndef TRITRACE_TSAN
  GTEST_SKIP() << "needs a ThreadSanitizer build (make test-tsan)";
#else
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  // TSan's exit status is non-zero (66) once it has reported anything, whatever exit() asks for.
  EXPECT_DEATH(
      {
        sibling_tasks_write_one_variable();
        std::exit(0);
      },
      "ThreadSanitizer: data race");
#endif
}

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
