// Kernel names and the runtime-dispatched kernel entry point.
#include "tritrace/geometry/intersect.h"

namespace tritrace {

std::string_view kernel_name(Kernel kernel) {
  switch (kernel) {
    case Kernel::kInverse:
      return "inverse";
    case Kernel::kCramer:
      return "cramer";
    case Kernel::kMollerTrumbore:
      return "moller-trumbore";
    case Kernel::kWatertight:
      return "watertight";
  }
  return "unknown";
}

std::optional<Kernel> parse_kernel(std::string_view name) {
  for (Kernel k : kAllKernels) {
    if (kernel_name(k) == name) return k;
  }
  return std::nullopt;
}

bool intersect_triangle(Kernel kernel, const Ray& ray, const glm::vec3& v0, const glm::vec3& e1,
                        const glm::vec3& e2, TriangleHit& out) {
  return with_kernel(kernel,
                     [&]<Kernel K>() { return intersect_triangle<K>(ray, v0, e1, e2, out); });
}

}  // namespace tritrace
