// The backend registry.
#include "tritrace/accel/make_accel.h"

#include <chrono>
#include <string>

#include "tritrace/accel/alpha_tested_accel.h"
#include "tritrace/accel/brute_force.h"
#include "tritrace/accel/bvh/bvh_accel.h"
#include "tritrace/accel/instanced_accel.h"
#include "tritrace/error.h"
#if TRITRACE_HAVE_EMBREE
#include <embree3/rtcore_config.h>

#include "tritrace/accel/embree_accel.h"
#endif

namespace tritrace {
namespace {
constexpr AccelKind kAll[] = {AccelKind::kBvh,          AccelKind::kBrute,     AccelKind::kEmbree,
                              AccelKind::kEmbreeSingle, AccelKind::kBvhSingle, AccelKind::kEmbree8,
                              AccelKind::kEmbreeRobust};

// bvh_build_for's threshold. The Morton build saves time per triangle and its tree costs time per
// ray, a lab ray less than a path-traced one, so it wins where the rays per triangle are few; one
// ray per triangle lies on the safe side of the break-even point for both integrators (the figures
// are in docs/PERFORMANCE.md, "A Morton-code build").
constexpr double kMortonRaysPerTriangle = 1.0;

bool is_embree(AccelKind kind) {
  return kind == AccelKind::kEmbree || kind == AccelKind::kEmbreeSingle ||
         kind == AccelKind::kEmbree8 || kind == AccelKind::kEmbreeRobust;
}
}  // namespace

std::string_view accel_name(AccelKind kind) {
  switch (kind) {
    case AccelKind::kBvh:
      return "bvh";
    case AccelKind::kBrute:
      return "brute";
    case AccelKind::kEmbree:
      return "embree";
    case AccelKind::kEmbreeSingle:
      return "embree-single";
    case AccelKind::kBvhSingle:
      return "bvh-single";
    case AccelKind::kEmbree8:
      return "embree8";
    case AccelKind::kEmbreeRobust:
      return "embree-robust";
  }
  return "unknown";
}

std::optional<AccelKind> parse_accel(std::string_view name) {
  for (AccelKind k : kAll) {
    if (accel_name(k) == name) return k;
  }
  return std::nullopt;
}

bool accel_available(AccelKind kind) {
  return !is_embree(kind) || TRITRACE_HAVE_EMBREE;
}

std::vector<AccelKind> available_accels() {
  std::vector<AccelKind> out;
  for (AccelKind k : kAll) {
    if (accel_available(k)) out.push_back(k);
  }
  return out;
}

std::string_view embree_version() {
#if TRITRACE_HAVE_EMBREE
  return RTC_VERSION_STRING;
#else
  return {};
#endif
}

Kernel default_kernel_for(AccelKind /*kind*/) {
  return kDefaultKernel;
}

std::string_view bvh_build_name(bvh::BuildMethod method) {
  return method == bvh::BuildMethod::kMorton ? "morton" : "sah";
}

std::optional<bvh::BuildMethod> parse_bvh_build(std::string_view name) {
  if (name == "sah") return bvh::BuildMethod::kBinnedSah;
  if (name == "morton") return bvh::BuildMethod::kMorton;
  return std::nullopt;
}

bvh::BuildMethod bvh_build_for(size_t triangles, double rays) {
  return rays < kMortonRaysPerTriangle * static_cast<double>(triangles)
             ? bvh::BuildMethod::kMorton
             : bvh::BuildMethod::kBinnedSah;
}

std::unique_ptr<Accel> make_accel(AccelKind kind, const TriangleMesh& mesh, Kernel kernel,
                                  AccelInfo* info, bvh::BuildMethod build) {
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<Accel> accel;
  AccelInfo local;
  switch (kind) {
    case AccelKind::kBrute:
      accel = std::make_unique<BruteForceAccel>(mesh, kernel);
      break;
    case AccelKind::kBvh:
    case AccelKind::kBvhSingle: {
      bvh::BuildConfig config = bvh::default_build_config(mesh.size());
      config.method = build;
      auto bvh = std::make_unique<BvhAccel>(
          mesh, kernel, config,
          kind == AccelKind::kBvh ? BvhTraversal::kAuto : BvhTraversal::kSingle);
      local.structure_bytes = bvh->tree().node_bytes();
      local.triangle_copy_bytes = bvh->tree().block_bytes();
      if (&bvh->closest_tree() != &bvh->tree()) {  // a small mesh's second tree
        local.structure_bytes += bvh->closest_tree().node_bytes();
        local.triangle_copy_bytes += bvh->closest_tree().block_bytes();
      }
      accel = std::move(bvh);
      break;
    }
    case AccelKind::kEmbree:
    case AccelKind::kEmbreeSingle:
    case AccelKind::kEmbree8:
    case AccelKind::kEmbreeRobust: {
#if TRITRACE_HAVE_EMBREE
      const EmbreeMode mode = kind == AccelKind::kEmbreeSingle ? EmbreeMode::kSingle
                              : kind == AccelKind::kEmbree8    ? EmbreeMode::kPacket8
                              : EmbreeAccel::native_packet16() ? EmbreeMode::kPacket16
                                                               : EmbreeMode::kPacket8;
      auto embree = std::make_unique<EmbreeAccel>(mesh, mode, kind == AccelKind::kEmbreeRobust);
      local.structure_bytes = embree->structure_bytes();
      accel = std::move(embree);
      break;
#else
      throw Error("--accel", std::string(accel_name(kind)) +
                                 ": this build has no Embree (install libembree-dev and "
                                 "rebuild with TRITRACE_WITH_EMBREE=ON)");
#endif
    }
  }
  local.build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (info) *info = local;
  return accel;
}

namespace {

// The structure over the scene's triangles, opaque all (make_accel below adds the alpha test).
std::unique_ptr<Accel> make_scene_structure(AccelKind kind, const Scene& scene, Kernel kernel,
                                            AccelInfo* info, bvh::BuildMethod build) {
  if (!scene.has_instances()) return make_accel(kind, scene.mesh, kernel, info, build);
  if (is_embree(kind)) {
    throw Error("--accel", std::string(accel_name(kind)) +
                               ": instanced scenes are not supported by the Embree backend (use "
                               "bvh or brute)");
  }
  const auto start = std::chrono::steady_clock::now();
  AccelInfo total;
  auto per_mesh = [&](const TriangleMesh& mesh) {
    AccelInfo one;
    std::unique_ptr<Accel> accel = make_accel(kind, mesh, kernel, &one, build);
    total.structure_bytes += one.structure_bytes;
    total.triangle_copy_bytes += one.triangle_copy_bytes;
    return accel;
  };
  auto accel =
      std::make_unique<InstancedAccel>(scene, per_mesh,
                                       kind == AccelKind::kBrute ? InstancedAccel::TopLevel::kBrute
                                                                 : InstancedAccel::TopLevel::kBvh);
  total.structure_bytes += accel->top_level_bytes();
  total.build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (info) *info = total;
  return accel;
}

}  // namespace

std::unique_ptr<Accel> make_accel(AccelKind kind, const Scene& scene, Kernel kernel,
                                  AccelInfo* info, bvh::BuildMethod build) {
  std::unique_ptr<Accel> accel = make_scene_structure(kind, scene, kernel, info, build);
  if (!has_alpha_tested_materials(scene)) return accel;
  return std::make_unique<AlphaTestedAccel>(scene, std::move(accel));
}

}  // namespace tritrace
