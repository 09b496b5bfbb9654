// One worker thread at a time draws (the others skip the tile's update rather than wait), and only
// after the next draw time has passed, so most calls cost one clock read and one compare.
#include "progress.h"

#include <algorithm>
#include <utility>

namespace tritrace::cli {
namespace {

constexpr int64_t kDelayNs = 1'000'000'000;  // no bar for renders shorter than about a second
constexpr int64_t kIntervalNs = 100'000'000;
constexpr int kBarWidth = 30;
constexpr int64_t kPhaseDelayNs = 300'000'000;  // phases shorter than this draw nothing

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

ProgressBar::ProgressBar(std::FILE* out)
    : out_(out), start_ns_(now_ns()), next_draw_ns_(start_ns_ + kDelayNs) {}

void ProgressBar::tiles_done(int done, int total) noexcept {
  total_.store(total, std::memory_order_relaxed);
  const int64_t now = now_ns();
  if (now < next_draw_ns_.load(std::memory_order_relaxed)) return;
  if (drawing_.exchange(true, std::memory_order_acquire)) return;
  next_draw_ns_.store(now + kIntervalNs, std::memory_order_relaxed);
  draw(done, total, now);
  shown_.store(true, std::memory_order_relaxed);
  drawing_.store(false, std::memory_order_release);
}

void ProgressBar::finish() noexcept {
  if (!shown_.load()) return;
  const int total = total_.load();
  draw(total, total, now_ns());
  std::fputc('\n', out_);
  std::fflush(out_);
}

void ProgressBar::draw(int done, int total, int64_t now) noexcept {
  const double fraction = total > 0 ? static_cast<double>(done) / total : 1.0;
  const double elapsed = static_cast<double>(now - start_ns_) * 1e-9;
  const int filled = static_cast<int>(fraction * kBarWidth);
  char bar[kBarWidth + 1];
  for (int i = 0; i < kBarWidth; ++i) bar[i] = i < filled ? '#' : '.';
  bar[kBarWidth] = '\0';
  char paths[64] = "";
  if (spp_ > 0 && elapsed > 0.0) {
    std::snprintf(paths, sizeof paths, "  %u spp, %.3g Mpaths/s", spp_,
                  fraction * static_cast<double>(total_paths_) / elapsed * 1e-6);
  }
  if (done < total && fraction > 0.0) {
    const double eta = elapsed * (1.0 - fraction) / fraction;
    std::fprintf(out_, "\r[%s] %3d%%  %.1f s elapsed, ETA %.1f s%s ", bar,
                 static_cast<int>(fraction * 100.0), elapsed, eta, paths);
  } else {
    std::fprintf(out_, "\r[%s] %3d%%  %.1f s elapsed%s             ", bar,
                 static_cast<int>(fraction * 100.0), elapsed, paths);
  }
  std::fflush(out_);
}

PhaseLine::PhaseLine(std::FILE* out, bool enabled, std::string what, const LoadProgress* progress)
    : out_(out), what_(std::move(what)), progress_(progress), start_ns_(now_ns()) {
  if (enabled) thread_ = std::thread([this] { run(); });
}

PhaseLine::~PhaseLine() {
  done();
}

void PhaseLine::done() noexcept {
  if (!thread_.joinable()) return;
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
  if (shown_) {
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "  %.1f s",
                  static_cast<double>(now_ns() - start_ns_) * 1e-9);
    const std::string line = what_ + seconds;
    std::fprintf(out_, "\r%s%*s\n", line.c_str(),
                 static_cast<int>(drawn_ > line.size() ? drawn_ - line.size() : 0), "");
    std::fflush(out_);
  }
}

void PhaseLine::run() {
  std::unique_lock lock(mutex_);
  if (wake_.wait_for(lock, std::chrono::nanoseconds(kPhaseDelayNs), [this] { return stop_; })) {
    return;
  }
  do {
    std::string line = what_;
    if (progress_ != nullptr) {
      const std::string step = progress_->describe();
      if (!step.empty()) line += "  " + step;
    }
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "  %.1f s",
                  static_cast<double>(now_ns() - start_ns_) * 1e-9);
    line += seconds;
    std::fprintf(out_, "\r%s%*s", line.c_str(),
                 static_cast<int>(drawn_ > line.size() ? drawn_ - line.size() : 0), "");
    std::fflush(out_);
    drawn_ = std::max(drawn_, line.size());
    shown_ = true;
  } while (!wake_.wait_for(lock, std::chrono::nanoseconds(kIntervalNs), [this] { return stop_; }));
}

}  // namespace tritrace::cli
