// What this tritrace binary is (version, commit, compiler, SIMD width, optional parts) and the CPU
// it runs on: printed by `tritrace --version` and recorded in `tritrace bench --json`, so that a
// figure can always be traced to the build and machine that made it.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace tritrace::cli {

std::string version_text();   // the lines `tritrace --version` prints
nlohmann::json build_json();  // the same as JSON fields, plus the CPU model
std::string cpu_model();      // /proc/cpuinfo's model name, or "unknown"

}  // namespace tritrace::cli
