// Screenshot files: the next free name in a folder, and writing the rendered Image itself with the
// project's PNG writer (an atomic write), so that it equals what `tritrace render` writes.
#pragma once

#include <filesystem>

namespace tritrace::view {

// `folder`/tritrace-view-NNN.png with the smallest NNN (from 001, three digits or more) that does
// not exist yet.
std::filesystem::path next_screenshot_path(const std::filesystem::path& folder);

}  // namespace tritrace::view
