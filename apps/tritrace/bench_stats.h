// Small statistics both `tritrace bench` modes report: medians of timed rounds and the process's
// peak resident memory.
#pragma once

#include <sys/resource.h>

#include <algorithm>
#include <vector>

namespace tritrace::cli {

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

inline long peak_rss_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;  // kilobytes on Linux
}

}  // namespace tritrace::cli
