// The render progress bar on stderr: percentage, elapsed time and ETA, shown only when stderr is a
// terminal and the render has run for about a second, redrawn at most ten times a second.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>

#include "tritrace/render/renderer.h"

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

}  // namespace tritrace::cli
