// One worker thread at a time draws (the others skip the tile's update rather than wait), and only
// after the next draw time has passed, so most calls cost one clock read and one compare.
#include "progress.h"

namespace tritrace::cli {
namespace {

constexpr int64_t kDelayNs = 1'000'000'000;  // no bar for renders shorter than about a second
constexpr int64_t kIntervalNs = 100'000'000;
constexpr int kBarWidth = 30;

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

}  // namespace tritrace::cli
