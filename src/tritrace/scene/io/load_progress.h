// How far a scene load has come, for a display on another thread (the CLI's phase line, the
// viewer's title): the loaders name the step they are in and count its work ("reading 43%",
// "parsing 80%", "adding triangles 12%"); the display polls describe(). A load reports to the
// LoadProgress its thread was given (LoadProgressScope), or nowhere.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

namespace tritrace {

class LoadProgress {
 public:
  // A new step of `total` units of work (0: a step whose size is not known); `step` must outlive
  // the load (a string literal).
  void begin(const char* step, uint64_t total);
  void advance(uint64_t units) { done_.fetch_add(units, std::memory_order_relaxed); }
  void set(uint64_t done) { done_.store(done, std::memory_order_relaxed); }

  // "reading 43%", the step alone when its size is not known, "" before the first step.
  std::string describe() const;

  // While set, describe() shows `other`'s progress (the importer's child process reports to a
  // LoadProgress in memory shared with it); nullptr goes back to this one's.
  void follow(const LoadProgress* other);

 private:
  std::atomic<const char*> step_{nullptr};
  std::atomic<uint64_t> done_{0};
  std::atomic<uint64_t> total_{0};
  mutable std::mutex follow_mutex_;
  const LoadProgress* follow_ = nullptr;
};

// The LoadProgress the calling thread's loads report to, or nullptr.
LoadProgress* load_progress();

// Makes `progress` the calling thread's for the scope's lifetime (nullptr: none).
class LoadProgressScope {
 public:
  explicit LoadProgressScope(LoadProgress* progress);
  ~LoadProgressScope();
  LoadProgressScope(const LoadProgressScope&) = delete;
  LoadProgressScope& operator=(const LoadProgressScope&) = delete;

 private:
  LoadProgress* previous_;
};

// The same calls on the calling thread's LoadProgress, doing nothing where it has none.
inline void progress_begin(const char* step, uint64_t total) {
  if (LoadProgress* p = load_progress()) p->begin(step, total);
}
inline void progress_advance(uint64_t units) {
  if (LoadProgress* p = load_progress()) p->advance(units);
}

}  // namespace tritrace
