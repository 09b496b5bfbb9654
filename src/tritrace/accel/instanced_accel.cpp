// The two-level traversal: a scalar walk of the binary top-level tree, each candidate instance's
// ray handed to its prototype's structure one ray at a time.
#include "tritrace/accel/instanced_accel.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tritrace/accel/bvh/wide_bvh.h"

namespace tritrace {
namespace {

// max over rows of sum |m[row][col]|: the infinity norm, a bound on how much the map stretches.
float norm_inf(const glm::mat3& m) {
  float best = 0.0f;
  for (int r = 0; r < 3; ++r) {
    best = std::max(best, std::abs(m[0][r]) + std::abs(m[1][r]) + std::abs(m[2][r]));
  }
  return best;
}

float largest_magnitude(glm::vec3 v) {
  return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
}

// Ize's robust slab test (as in the wide BVH's traversal): far distances scaled by 1 + 2 gamma(3).
// Returns the entry distance, or +inf when the ray misses the box grown by `pad` on each side.
float enter_box(const Bounds3& b, float pad, const Ray& ray, glm::vec3 inv_dir, float tmax) {
  float t0 = ray.tmin, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    float near = (b.lo[a] - pad - ray.origin[a]) * inv_dir[a];
    float far = (b.hi[a] + pad - ray.origin[a]) * inv_dir[a];
    if (near > far) std::swap(near, far);
    far *= bvh::kFarScale;
    // NaN (0 * inf, the ray on a slab's plane along it) is ignored: the slab does not cut.
    if (near > t0) t0 = near;
    if (far < t1) t1 = far;
  }
  return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
}

}  // namespace

Ray object_space_ray(const Instance& instance, const Ray& world_ray) {
  Ray r = world_ray;
  r.origin = instance.to_object.apply(world_ray.origin);
  r.dir = instance.to_object.apply_vector(world_ray.dir);
  return r;
}

InstancedAccel::InstancedAccel(const Scene& scene, const MeshAccelFactory& make_mesh_accel,
                               TopLevel top)
    : scene_(scene), top_(top) {
  if (!scene.mesh.empty()) mesh_accel_ = make_mesh_accel(scene.mesh);
  prototype_accels_.reserve(scene.prototypes.size());
  for (const TriangleMesh& p : scene.prototypes) prototype_accels_.push_back(make_mesh_accel(p));
  // A hit the prototype's structure finds lies on the object-space ray, which is the world ray
  // moved with rounding: in world space it can be off the world ray by a few ulps of the ray's
  // origin and of the instance's coordinates, stretched by at most the transform's condition
  // number. Each box is grown by 2^-16 times that, far above the handful of ulps the rounding can
  // take, so the top level never drops an instance that the prototype's structure would hit.
  std::vector<Bounds3> prototype_bounds;
  for (const TriangleMesh& p : scene.prototypes) prototype_bounds.push_back(p.bounds());
  boxes_.reserve(scene.instances.size());
  origin_pad_.reserve(scene.instances.size());
  for (const Instance& inst : scene.instances) {
    const float cond =
        std::max(1.0f, norm_inf(inst.to_world.linear) * norm_inf(inst.to_object.linear));
    Bounds3 b = instance_bounds(prototype_bounds[inst.prototype], inst);
    const float size = std::max({largest_magnitude(b.lo), largest_magnitude(b.hi),
                                 largest_magnitude(inst.to_world.translation)});
    const float pad = 0x1p-16f * cond * size;
    b.lo -= glm::vec3(pad);
    b.hi += glm::vec3(pad);
    boxes_.push_back(b);
    origin_pad_.push_back(0x1p-16f * cond);
  }
  if (top_ == TopLevel::kBvh && !boxes_.empty()) {
    bvh::BuildConfig config;
    config.max_leaf_size = 1;
    config.block_size = 1;
    tree_ = bvh::build_binned_sah(boxes_, config);
  }
}

size_t InstancedAccel::top_level_bytes() const {
  return tree_.nodes.size() * sizeof(bvh::BinaryNode) + tree_.prim_index.size() * sizeof(uint32_t) +
         boxes_.size() * sizeof(Bounds3) + origin_pad_.size() * sizeof(float);
}

template <typename Visit, typename TMax>
void InstancedAccel::for_each_candidate(const Ray& ray, TMax&& tmax, Visit&& visit) const {
  const size_t n = scene_.instances.size();
  if (top_ == TopLevel::kBrute) {
    for (size_t i = 0; i < n; ++i) {
      if (!visit(static_cast<uint32_t>(i))) return;
    }
    return;
  }
  if (tree_.nodes.empty()) return;
  const glm::vec3 inv_dir(1.0f / ray.dir.x, 1.0f / ray.dir.y, 1.0f / ray.dir.z);
  const float origin_size = largest_magnitude(ray.origin);
  // Inner nodes' boxes hold their instances' padded boxes; they are grown by the largest
  // per-origin padding of the scene so they stay conservative for every instance below them.
  float max_origin_pad = 0.0f;
  for (float p : origin_pad_) max_origin_pad = std::max(max_origin_pad, p);
  const float node_pad = max_origin_pad * origin_size;

  struct Entry {
    uint32_t node;
    float t;
  };
  Entry stack[bvh::kStackSize];
  int sp = 0;
  const bvh::BinaryNode& root = tree_.nodes[0];
  const float root_t = enter_box(root.bounds, node_pad, ray, inv_dir, tmax());
  if (root_t == std::numeric_limits<float>::infinity()) return;
  stack[sp++] = {0, root_t};
  while (sp > 0) {
    const Entry e = stack[--sp];
    if (e.t > tmax()) continue;
    const bvh::BinaryNode& node = tree_.nodes[e.node];
    if (node.is_leaf()) {
      for (uint32_t k = node.first; k < node.first + node.count; ++k) {
        const uint32_t i = tree_.prim_index[k];
        if (enter_box(boxes_[i], origin_pad_[i] * origin_size, ray, inv_dir, tmax()) ==
            std::numeric_limits<float>::infinity()) {
          continue;
        }
        if (!visit(i)) return;
      }
      continue;
    }
    const uint32_t children[2] = {node.first, node.right};
    float t[2];
    for (int c = 0; c < 2; ++c) {
      t[c] = enter_box(tree_.nodes[children[c]].bounds, node_pad, ray, inv_dir, tmax());
    }
    // Nearer child on top of the stack.
    const int nearer = t[1] < t[0] ? 1 : 0;
    for (int c : {1 - nearer, nearer}) {
      if (t[c] != std::numeric_limits<float>::infinity()) stack[sp++] = {children[c], t[c]};
    }
  }
}

Hit InstancedAccel::closest(const Ray& ray) const {
  Hit best;
  if (mesh_accel_) mesh_accel_->intersect_incoherent({&ray, 1}, {&best, 1});
  // Closer, or as close with a lower number: the order of the flattened mesh.
  for_each_candidate(
      ray, [&] { return std::min(ray.tmax, best.t); },
      [&](uint32_t i) {
        const Instance& inst = scene_.instances[i];
        Ray r = object_space_ray(inst, ray);
        r.tmax = std::min(ray.tmax, best.t);
        Hit h;
        prototype_accels_[inst.prototype]->intersect_incoherent({&r, 1}, {&h, 1});
        if (h.found()) {
          const uint32_t prim = inst.first_prim + h.prim;
          if (h.t < best.t || (h.t == best.t && prim < best.prim)) best = {h.t, h.u, h.v, prim};
        }
        return true;
      });
  return best;
}

bool InstancedAccel::any(const Ray& ray) const {
  uint8_t blocked = 0;
  if (mesh_accel_) mesh_accel_->occluded_incoherent({&ray, 1}, {&blocked, 1});
  if (blocked) return true;
  for_each_candidate(
      ray, [&] { return ray.tmax; },
      [&](uint32_t i) {
        const Instance& inst = scene_.instances[i];
        const Ray r = object_space_ray(inst, ray);
        prototype_accels_[inst.prototype]->occluded_incoherent({&r, 1}, {&blocked, 1});
        return blocked == 0;
      });
  return blocked != 0;
}

void InstancedAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  for (size_t i = 0; i < rays.size(); ++i) hits[i] = closest(rays[i]);
}

void InstancedAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any(rays[i]) ? 1 : 0;
}

}  // namespace tritrace
