// LoadProgress and the thread's current one.
#include "tritrace/scene/io/load_progress.h"

#include <algorithm>

namespace tritrace {
namespace {

thread_local LoadProgress* current_progress = nullptr;

}  // namespace

void LoadProgress::begin(const char* step, uint64_t total) {
  // A reader between these stores sees the new step with no total (the step alone) or with a
  // count from zero, never the old count against the new total.
  total_.store(0, std::memory_order_relaxed);
  done_.store(0, std::memory_order_relaxed);
  step_.store(step, std::memory_order_release);
  total_.store(total, std::memory_order_release);
}

std::string LoadProgress::describe() const {
  {
    const std::lock_guard lock(follow_mutex_);
    if (follow_ != nullptr) return follow_->describe();
  }
  const uint64_t total = total_.load(std::memory_order_acquire);
  const char* step = step_.load(std::memory_order_acquire);
  if (step == nullptr) return "";
  if (total == 0) return step;
  const uint64_t done = std::min(done_.load(std::memory_order_relaxed), total);
  return std::string(step) + " " + std::to_string(done * 100 / total) + "%";
}

void LoadProgress::follow(const LoadProgress* other) {
  const std::lock_guard lock(follow_mutex_);
  follow_ = other;
}

LoadProgress* load_progress() {
  return current_progress;
}

LoadProgressScope::LoadProgressScope(LoadProgress* progress) : previous_(current_progress) {
  current_progress = progress;
}

LoadProgressScope::~LoadProgressScope() {
  current_progress = previous_;
}

}  // namespace tritrace
