// The render progress bar on stderr, and the phase line shown before it while a scene loads and
// its BVH builds. The bar: percentage, elapsed time and ETA, shown only when stderr is a
// terminal and the render has run for about a second, redrawn at most ten times a second.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>

#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/load_progress.h"

namespace tritrace::cli {

class ProgressBar final : public RenderProgress {
 public:
  explicit ProgressBar(std::FILE* out);

  void tiles_done(int done, int total) noexcept override;
  // For sampled renders: the bar also shows the samples per pixel and the paths per second.
  void show_paths(uint64_t total_paths, uint32_t spp) noexcept {
    total_paths_ = total_paths;
    spp_ = spp;
  }
  // Draws the bar at 100% and ends its line, if it was ever drawn.
  void finish() noexcept;

 private:
  void draw(int done, int total, int64_t now_ns) noexcept;

  std::FILE* out_;
  int64_t start_ns_;
  std::atomic<int64_t> next_draw_ns_;
  std::atomic<bool> drawing_{false};
  std::atomic<bool> shown_{false};
  std::atomic<int> total_{0};
  uint64_t total_paths_ = 0;  // set before the render starts
  uint32_t spp_ = 0;
};

// A phase before the render (loading the scene, building the BVH), which can take seconds on big
// models: on a terminal, once it has run for kPhaseDelay, one line `building BVH  1.3 s` redrawn
// by a thread of its own every tenth of a second, with what `progress` says in between when given
// (`loading big.ply  parsing 43%  1.3 s`), and finished with the phase's total time when it
// ends. Nothing when `enabled` is false (not a terminal, or --quiet).
class PhaseLine final {
 public:
  PhaseLine(std::FILE* out, bool enabled, std::string what, const LoadProgress* progress = nullptr);
  PhaseLine(const PhaseLine&) = delete;
  PhaseLine& operator=(const PhaseLine&) = delete;
  ~PhaseLine();
  void done() noexcept;  // ends the phase; the destructor calls it too

 private:
  void run();

  std::FILE* out_;
  std::string what_;
  const LoadProgress* progress_;
  int64_t start_ns_;
  size_t drawn_ = 0;  // characters of the last line drawn, to blank what a shorter one leaves
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  bool shown_ = false;
  std::thread thread_;
};

}  // namespace tritrace::cli
