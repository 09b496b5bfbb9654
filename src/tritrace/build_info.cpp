// The build's facts: the version from CMake, the commit from build_commit.h (written by
// cmake/write_build_info.cmake at every build, rewritten only when it changes, so that a new
// commit recompiles this one file) and the lane count the SIMD code was compiled for.
#include "tritrace/build_info.h"

#include "build_commit.h"
#include "tritrace/math/simd_lanes.h"

namespace tritrace {

std::string_view build_version() {
  return TRITRACE_VERSION;
}

std::string_view build_commit() {
  return TRITRACE_COMMIT;
}

int build_simd_lanes() {
  return simd::kLanes;
}

std::string build_text() {
  return "version=" + std::string(build_version()) + " commit=" + std::string(build_commit()) +
         " simd=" + std::to_string(build_simd_lanes());
}

}  // namespace tritrace
