// The build's facts come from the compiler and the build (the version and commit come from
// the library, tritrace/build_info.h); the CPU's from /proc/cpuinfo at run time.
#include "build_info.h"

#include <fstream>

#include "tritrace/accel/make_accel.h"
#include "tritrace/build_info.h"
#include "tritrace/image/exr.h"
#include "tritrace/math/simd_lanes.h"

namespace tritrace::cli {
namespace {

std::string compiler() {
#if defined(__clang__)
  return "clang " __clang_version__;
#elif defined(__GNUC__)
  return "g++ " __VERSION__;
#else
  return "unknown compiler";
#endif
}

std::string simd() {
  const int lanes = simd::kLanes;
  if (lanes == 16) return "AVX-512, 16 float lanes";
  if (lanes == 8) return "AVX2, 8 float lanes";
  return "scalar (no AVX2)";
}

bool have_mpi() {
// apps/tritrace/CMakeLists.txt defines TRITRACE_HAVE_MPI as 1 or 0.
#if TRITRACE_HAVE_MPI
  return true;
#else
  return false;
#endif
}

}  // namespace

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
  }
  return "unknown";
}

std::string version_text() {
  const std::string embree(embree_version());
  std::string text = "tritrace " + std::string(build_version()) + " (commit " +
                     std::string(build_commit()) + ")\n";
  text += "compiler: " + compiler() + "\n";
  text += "SIMD: " + simd() + "\n";
  text += "Embree: " + (embree.empty() ? std::string("not built in") : embree) + "\n";
  text += "OpenEXR: " + std::string(openexr_version()) + "\n";
  text += std::string("MPI: ") + (have_mpi() ? "built in (render --mpi)" : "not built in");
  return text;
}

nlohmann::json build_json() {
  const std::string embree(embree_version());
  return {{"version", std::string(build_version())},
          {"commit", std::string(build_commit())},
          {"compiler", compiler()},
          {"simd_lanes", build_simd_lanes()},
          {"embree_version", embree.empty() ? nlohmann::json() : nlohmann::json(embree)},
          {"openexr_version", std::string(openexr_version())},
          {"mpi", have_mpi()},
          {"cpu", cpu_model()}};
}

}  // namespace tritrace::cli
