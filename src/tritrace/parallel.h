// Parallel loops, reductions and task groups over TBB whose hand-overs of work ThreadSanitizer can
// follow. Debian's libtbb.so is not built with TSan, so TSan cannot see TBB hand a task to another
// thread, nor a waiting thread learn that the tasks finished, and reports races between a task and
// the code before the hand-over or after the wait. Here, in a TSan build, each task's own address
// is its synchronisation address: the thread that hands it over releases it and the task acquires
// it first; each task releases its group's address when it ends, and wait() acquires that. These
// are edges TBB guarantees, and no more: a task releases only its group's address, which only
// wait() acquires, so these annotations order no task after another's work (one global address
// did: each task acquired every earlier task's release). Otherwise these are plain TBB task groups.
//
// Everything is built on tbb::task_group rather than parallel_for / parallel_reduce: TBB's loops
// keep their completion count on the caller's stack and a worker still reads it after its last
// task, which TSan reports once the caller reuses that stack; a task_group's destructor reads its
// count with an (instrumented) acquire after every worker's last access.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__SANITIZE_THREAD__)
#define TRITRACE_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TRITRACE_TSAN 1
#endif
#endif
#ifdef TRITRACE_TSAN
extern "C" void __tsan_acquire(void* addr);
extern "C" void __tsan_release(void* addr);
#endif

namespace tritrace::parallel {
namespace detail {

inline void release([[maybe_unused]] const void* address) {
#ifdef TRITRACE_TSAN
  __tsan_release(const_cast<void*>(address));
#endif
}

inline void acquire([[maybe_unused]] const void* address) {
#ifdef TRITRACE_TSAN
  __tsan_acquire(const_cast<void*>(address));
#endif
}

// How many chunks a range is split into: at most four per thread of the current arena (for
// balance), none smaller than the range's grain size.
template <typename Index>
size_t chunk_count(const tbb::blocked_range<Index>& range) {
  const size_t size = range.size();
  const size_t grain = std::max<size_t>(1, range.grainsize());
  const size_t most = 4 * static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  return std::clamp<size_t>((size + grain - 1) / grain, 1, most);
}

// Chunk k of `chunks` nearly equal parts of `range`.
template <typename Index>
tbb::blocked_range<Index> chunk(const tbb::blocked_range<Index>& range, size_t k, size_t chunks) {
  const size_t size = range.size();
  const Index b = range.begin() + static_cast<Index>(size * k / chunks);
  const Index e = range.begin() + static_cast<Index>(size * (k + 1) / chunks);
  return tbb::blocked_range<Index>(b, e);
}

}  // namespace detail

// tbb::task_group: run(f) hands f() to another thread (or runs it in wait()), wait() returns once
// every f has run.
class TaskGroup {
 public:
  TaskGroup() = default;
  TaskGroup(const TaskGroup&) = delete;
  TaskGroup& operator=(const TaskGroup&) = delete;
  ~TaskGroup() = default;

  template <typename F>
  void run(F&& f) {
    group_.run(Task<std::decay_t<F>>(std::forward<F>(f), &done_));
  }
  void wait() {
    group_.wait();
    detail::acquire(&done_);
  }

 private:
  // TBB moves the task into its own memory on the spawning thread, so each move or copy releases
  // the new task's own address (`this`) after it; the thread that runs it acquires that address
  // before reading any of its members (the address is known without reading the task, where an
  // address kept in a member would itself be read before the acquire), and releases the group's
  // when it has finished.
  template <typename F>
  class Task {
   public:
    Task(F f, const char* done) : fn_(std::move(f)), done_(done) {}
    Task(Task&& other) noexcept : fn_(std::move(other.fn_)), done_(other.done_) {
      detail::release(this);
    }
    Task(const Task& other) : fn_(other.fn_), done_(other.done_) { detail::release(this); }
    Task& operator=(const Task&) = delete;
    Task& operator=(Task&&) = delete;
    ~Task() = default;

    void operator()() const {
      detail::acquire(this);
      fn_();
      detail::release(done_);
    }

   private:
    F fn_;
    const char* done_;
  };
  tbb::task_group group_;
  // The address every task of this group releases when it ends, and wait() acquires.
  char done_ = 0;
};

// body(const blocked_range&) over chunks of `range` (at least its grain size each) in parallel.
template <typename Index, typename Body>
void for_range(const tbb::blocked_range<Index>& range, const Body& body) {
  if (range.empty()) return;
  const size_t chunks = detail::chunk_count(range);
  if (chunks == 1) return body(range);
  TaskGroup group;
  for (size_t k = 1; k < chunks; ++k) {
    group.run([&body, &range, k, chunks] { body(detail::chunk(range, k, chunks)); });
  }
  body(detail::chunk(range, 0, chunks));
  group.wait();
}

// The reduction of `range` in parallel: body(const blocked_range&, Value) returns the value
// extended by a chunk, starting from `identity`; join(Value, const Value&) returns two combined.
// Chunks are joined in order on the calling thread, so the result never depends on timing (with a
// join that is not associative it may depend on the arena's thread count, which sets the chunks).
template <typename Index, typename Value, typename Body, typename Join>
[[nodiscard]] Value reduce(const tbb::blocked_range<Index>& range, const Value& identity,
                           const Body& body, const Join& join) {
  if (range.empty()) return identity;
  const size_t chunks = detail::chunk_count(range);
  if (chunks == 1) return body(range, identity);
  std::vector<Value> partial(chunks, identity);
  {
    TaskGroup group;
    for (size_t k = 1; k < chunks; ++k) {
      group.run(
          [&, k] { partial[k] = body(detail::chunk(range, k, chunks), std::move(partial[k])); });
    }
    partial[0] = body(detail::chunk(range, 0, chunks), std::move(partial[0]));
    group.wait();
  }
  Value out = std::move(partial[0]);
  for (size_t k = 1; k < chunks; ++k) {
    out = join(std::move(out), static_cast<const Value&>(partial[k]));
  }
  return out;
}

// f() inside a TBB arena of `threads` threads. TBB gives all arenas together at most
// max_allowed_parallelism threads, by default the number of cores, and an arena asked for more
// prints "number of workers is currently limited" and gets fewer; the limit is raised for as long
// as f runs, so that the arena has every thread asked for.
template <typename F>
void in_arena(int threads, const F& f) {
  threads = std::max(1, threads);
  std::optional<tbb::global_control> allow_threads;
  if (static_cast<size_t>(threads) >
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)) {
    allow_threads.emplace(tbb::global_control::max_allowed_parallelism,
                          static_cast<size_t>(threads));
  }
  tbb::task_arena arena(threads);
  arena.execute(f);
}

// f() on `threads` threads at once (the caller's among them), in an arena of that many (in_arena).
template <typename F>
void on_threads(int threads, const F& f) {
  threads = std::max(1, threads);
  in_arena(threads, [&] {
    TaskGroup group;
    for (int t = 1; t < threads; ++t) group.run(f);
    f();
    group.wait();
  });
}

}  // namespace tritrace::parallel
