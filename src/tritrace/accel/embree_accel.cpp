// The Embree backend. Denormals are flushed to zero around every batch (Embree's recommendation
// for speed), packets are filled from consecutive rays of a batch, which are neighbouring pixels
// of a tile, and incoherent batches (bounce and shadow rays of paths) go ray by ray.
#include "tritrace/accel/embree_accel.h"

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <string>

#include "tritrace/error.h"

namespace tritrace {
namespace {

// Sets FTZ/DAZ for the current thread for the lifetime of the object, then restores MXCSR.
class FlushDenormals {
 public:
  FlushDenormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | 0x8040); }
  ~FlushDenormals() { _mm_setcsr(saved_); }

 private:
  unsigned saved_;
};

bool count_bytes(void* user, ssize_t bytes, bool) {
  static_cast<std::atomic<ssize_t>*>(user)->fetch_add(bytes, std::memory_order_relaxed);
  return true;
}

RTCRay to_rtc(const Ray& r) {
  return {r.origin.x, r.origin.y, r.origin.z, r.tmin,      r.dir.x, r.dir.y,
          r.dir.z,    0.0f,       r.tmax,     0xFFFFFFFFu, 0,       0};
}

Hit to_hit(float tfar, float u, float v, unsigned geom, unsigned prim) {
  if (geom == RTC_INVALID_GEOMETRY_ID) return Hit{};
  return Hit{tfar, u, v, prim};
}

template <int N, typename RayHitN>
void fill_packet(std::span<const Ray> rays, size_t first, size_t count, RayHitN& packet,
                 int* valid) {
  for (size_t k = 0; k < static_cast<size_t>(N); ++k) {
    valid[k] = k < count ? -1 : 0;
    const Ray& r = rays[first + std::min(k, count - 1)];
    packet.ray.org_x[k] = r.origin.x, packet.ray.org_y[k] = r.origin.y;
    packet.ray.org_z[k] = r.origin.z;
    packet.ray.dir_x[k] = r.dir.x, packet.ray.dir_y[k] = r.dir.y, packet.ray.dir_z[k] = r.dir.z;
    packet.ray.tnear[k] = r.tmin, packet.ray.tfar[k] = r.tmax;
    packet.ray.time[k] = 0.0f;
    packet.ray.mask[k] = 0xFFFFFFFFu;
    packet.ray.id[k] = static_cast<unsigned>(k);
    packet.ray.flags[k] = 0;
    packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
  }
}

}  // namespace

struct EmbreeAccel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::atomic<ssize_t> bytes{0};

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  // One ray at a time. rtcInitIntersectContext sets RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT (zero)
  // already; the flag is named so that the hint is stated where it matters.
  void intersect_singles(std::span<const Ray> rays, std::span<Hit> hits,
                         RTCIntersectContextFlags flags) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = flags;
    for (size_t i = 0; i < rays.size(); ++i) {
      RTCRayHit rh;
      rh.ray = to_rtc(rays[i]);
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &context, &rh);
      hits[i] = to_hit(rh.ray.tfar, rh.hit.u, rh.hit.v, rh.hit.geomID, rh.hit.primID);
    }
  }

  void occluded_singles(std::span<const Ray> rays, std::span<uint8_t> out,
                        RTCIntersectContextFlags flags) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = flags;
    for (size_t i = 0; i < rays.size(); ++i) {
      RTCRay ray = to_rtc(rays[i]);
      rtcOccluded1(scene, &context, &ray);
      out[i] = ray.tfar < 0.0f ? 1 : 0;
    }
  }

  template <int N, typename RayHitN, typename IntersectN>
  void intersect_packets(std::span<const Ray> rays, std::span<Hit> hits, IntersectN fn) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (size_t first = 0; first < rays.size(); first += N) {
      const size_t count = std::min<size_t>(N, rays.size() - first);
      alignas(64) RayHitN packet;
      alignas(64) int valid[N];
      fill_packet<N>(rays, first, count, packet, valid);
      fn(valid, scene, &context, &packet);
      for (size_t k = 0; k < count; ++k) {
        hits[first + k] = to_hit(packet.ray.tfar[k], packet.hit.u[k], packet.hit.v[k],
                                 packet.hit.geomID[k], packet.hit.primID[k]);
      }
    }
  }

  template <int N, typename RayHitN, typename OccludedN>
  void occluded_packets(std::span<const Ray> rays, std::span<uint8_t> out, OccludedN fn) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (size_t first = 0; first < rays.size(); first += N) {
      const size_t count = std::min<size_t>(N, rays.size() - first);
      alignas(64) RayHitN packet;
      alignas(64) int valid[N];
      fill_packet<N>(rays, first, count, packet, valid);
      fn(valid, scene, &context, &packet.ray);
      for (size_t k = 0; k < count; ++k) out[first + k] = packet.ray.tfar[k] < 0.0f ? 1 : 0;
    }
  }
};

bool EmbreeAccel::native_packet16() {
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) return false;
  const bool native = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
  rtcReleaseDevice(device);
  return native;
}

EmbreeAccel::EmbreeAccel(const TriangleMesh& mesh, EmbreeMode mode, bool robust)
    : impl_(std::make_unique<Impl>()), mode_(mode), robust_(robust) {
  const FlushDenormals ftz;
  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device) throw Error("embree", "cannot create a device");
  rtcSetDeviceMemoryMonitorFunction(impl_->device, count_bytes, &impl_->bytes);
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  if (robust) rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);

  const size_t n = mesh.size();
  if (n > 0) {
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    if (!vertices || !indices) throw Error("embree", "cannot allocate geometry buffers");
    for (size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 p = mesh.vertex(i, c);
        const size_t k = 9 * i + 3 * static_cast<size_t>(c);
        vertices[k + 0] = p.x;
        vertices[k + 1] = p.y;
        vertices[k + 2] = p.z;
        indices[3 * i + c] = static_cast<unsigned>(3 * i + c);
      }
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  const ssize_t buffers = impl_->bytes.load();
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE) {
    throw Error("embree", "building the scene failed");
  }
  structure_bytes_ = static_cast<size_t>(std::max<ssize_t>(0, impl_->bytes.load() - buffers));
}

EmbreeAccel::~EmbreeAccel() = default;

void EmbreeAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  const FlushDenormals ftz;
  switch (mode_) {
    case EmbreeMode::kPacket8:
      return impl_->intersect_packets<8, RTCRayHit8>(rays, hits, rtcIntersect8);
    case EmbreeMode::kPacket16:
      return impl_->intersect_packets<16, RTCRayHit16>(rays, hits, rtcIntersect16);
    case EmbreeMode::kSingle:
      break;
  }
  impl_->intersect_singles(rays, hits, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
}

void EmbreeAccel::occluded(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  const FlushDenormals ftz;
  switch (mode_) {
    case EmbreeMode::kPacket8:
      return impl_->occluded_packets<8, RTCRayHit8>(rays, occluded, rtcOccluded8);
    case EmbreeMode::kPacket16:
      return impl_->occluded_packets<16, RTCRayHit16>(rays, occluded, rtcOccluded16);
    case EmbreeMode::kSingle:
      break;
  }
  impl_->occluded_singles(rays, occluded, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
}

void EmbreeAccel::intersect_incoherent(std::span<const Ray> rays, std::span<Hit> hits) const {
  const FlushDenormals ftz;
  impl_->intersect_singles(rays, hits, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
}

void EmbreeAccel::occluded_incoherent(std::span<const Ray> rays,
                                      std::span<uint8_t> occluded) const {
  const FlushDenormals ftz;
  impl_->occluded_singles(rays, occluded, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
}

}  // namespace tritrace
