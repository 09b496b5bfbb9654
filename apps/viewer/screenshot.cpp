// Screenshot numbering.
#include "screenshot.h"

#include <cstdio>

namespace tritrace::view {

std::filesystem::path next_screenshot_path(const std::filesystem::path& folder) {
  for (int n = 1;; ++n) {
    char name[64];
    std::snprintf(name, sizeof name, "tritrace-view-%03d.png", n);
    std::filesystem::path path = folder / name;
    std::error_code ec;
    if (!std::filesystem::exists(std::filesystem::symlink_status(path, ec))) return path;
  }
}

}  // namespace tritrace::view
