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
  switch (kernel) {
    case Kernel::kInverse:
      return intersect_triangle<Kernel::kInverse>(ray, v0, e1, e2, out);
    case Kernel::kCramer:
      return intersect_triangle<Kernel::kCramer>(ray, v0, e1, e2, out);
    case Kernel::kMollerTrumbore:
      return intersect_triangle<Kernel::kMollerTrumbore>(ray, v0, e1, e2, out);
  }
  return false;
}

}  // namespace tritrace
