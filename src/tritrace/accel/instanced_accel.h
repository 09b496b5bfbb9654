// InstancedAccel: the two-level structure for scenes with instances. A top level over the
// instances' world boxes (a binned SAH tree, or every instance in turn for the brute-force
// oracle) and below it one structure per prototype mesh, built once however often it is placed;
// rays are moved into each instance's object space without renormalising the direction, so t is
// the same in both spaces.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "tritrace/accel/accel.h"
#include "tritrace/accel/bvh/binned_sah_builder.h"
#include "tritrace/scene/scene.h"

namespace tritrace {

// The ray in the instance's object space: origin and direction through to_object, tmin and tmax
// unchanged. One function for every traversal, so they all test the same rays.
Ray object_space_ray(const Instance& instance, const Ray& world_ray);

class InstancedAccel final : public Accel {
 public:
  using MeshAccelFactory = std::function<std::unique_ptr<Accel>(const TriangleMesh&)>;
  enum class TopLevel {
    kBvh,    // a binned SAH tree over the instances' world boxes
    kBrute,  // every instance, in order: the oracle
  };

  // Keeps a reference to `scene`, which must outlive the accel. `make_mesh_accel` builds the
  // structure for the scene's own mesh (if not empty) and for each prototype. Hits name the
  // scene's triangle numbering (Scene::triangle), so the instance is Scene::instance_of(prim);
  // on an exact tie in t the lower number wins, as for one flattened mesh.
  InstancedAccel(const Scene& scene, const MeshAccelFactory& make_mesh_accel, TopLevel top);

  using Accel::intersect;
  using Accel::occluded;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const override;

  size_t top_level_bytes() const;

 private:
  Hit closest(const Ray& ray) const;
  bool any(const Ray& ray) const;
  // Calls visit(instance index) for each instance whose padded box the ray may enter before
  // tmax(); visit returns false to stop.
  template <typename Visit, typename TMax>
  void for_each_candidate(const Ray& ray, TMax&& tmax, Visit&& visit) const;

  const Scene& scene_;
  std::unique_ptr<Accel> mesh_accel_;  // the scene's own mesh; null when empty
  std::vector<std::unique_ptr<Accel>> prototype_accels_;
  std::vector<Bounds3> boxes_;     // per instance, world space, padded for rounding (.cpp)
  std::vector<float> origin_pad_;  // per instance: padding per unit of the ray origin's size
  TopLevel top_;
  bvh::BinaryBvh tree_;
};

}  // namespace tritrace
