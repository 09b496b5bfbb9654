// What this build of the library is: its version, the git commit it was built from and its SIMD
// width. A render's identity carries them (partial films of different builds may differ in their
// last bits), and `tritrace --version` prints them.
#pragma once

#include <string>
#include <string_view>

namespace tritrace {

std::string_view build_version();  // the project's version, "0.1.0"
std::string_view build_commit();   // `git describe --always --dirty`, or "unknown"
int build_simd_lanes();            // float lanes of the SIMD code: 16, 8, or 0 (scalar)

// "version=0.1.0 commit=f4e13cb2a1b0 simd=8": the build as a render identity names it.
std::string build_text();

}  // namespace tritrace
