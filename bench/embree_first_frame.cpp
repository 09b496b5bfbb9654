// tritrace_embree_first_frame: issue 13's "minimal Embree program", the yardstick for tritrace's
// time to first pixel. It reads a binary PLY with a plain reader of its own, puts the lab box's
// 30 triangles and the PLY's triangles into one Embree scene of medium build quality, traces one
// primary ray per pixel of one frame on every core, and prints the phase times and peak memory.
//
//   tritrace_embree_first_frame MESH.ply [WIDTH HEIGHT]   (default 1920 x 1080)
//
// The camera is the one of scenes/benchmarks/sphere10m_first_frame.json (the lab's: at (0, 0, -3)
// looking at the origin, world y down, focal length = height), built with the library's Camera.
// Only the layout scripts/make_displaced_sphere_ply.py writes is read: a little-endian binary
// `vertex` element of float x, y, z and a `face` element of one `list uchar int` of three indices.
#include <embree3/rtcore.h>
#include <fcntl.h>
#include <pmmintrin.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <unistd.h>
#include <xmmintrin.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "tritrace/scene/camera.h"
#include "tritrace/scene/cornell_box.h"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A read-only mapping of a whole file.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0) throw std::runtime_error(std::strerror(errno));
    struct stat info {};
    if (::fstat(fd, &info) != 0 || info.st_size <= 0) {
      ::close(fd);
      throw std::runtime_error("empty or unreadable file");
    }
    size_ = static_cast<size_t>(info.st_size);
    void* data = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    ::close(fd);
    if (data == MAP_FAILED) throw std::runtime_error(std::strerror(errno));
    data_ = static_cast<const char*>(data);
    ::madvise(data, size_, MADV_SEQUENTIAL);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  ~MappedFile() { ::munmap(const_cast<char*>(data_), size_); }

  const char* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

struct PlyLayout {
  size_t vertices = 0;
  size_t faces = 0;
  size_t body = 0;  // offset of the first vertex
};

// Reads the header and insists on exactly the layout the script writes (comments aside).
PlyLayout read_header(const MappedFile& file) {
  const std::string_view text(file.data(), std::min<size_t>(file.size(), 4096));
  const size_t end = text.find("end_header\n");
  if (end == std::string_view::npos) throw std::runtime_error("no PLY header (end_header)");
  std::istringstream lines(std::string(text.substr(0, end)));
  std::string line;
  std::string expected[] = {"ply",
                            "format binary_little_endian 1.0",
                            "element vertex",
                            "property float x",
                            "property float y",
                            "property float z",
                            "element face",
                            "property list uchar int vertex_indices"};
  PlyLayout layout;
  size_t next = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("comment", 0) == 0 || line.rfind("obj_info", 0) == 0) continue;
    if (next == std::size(expected)) throw std::runtime_error("unexpected header line: " + line);
    const std::string& want = expected[next];
    if (want.rfind("element", 0) == 0) {
      if (line.rfind(want + " ", 0) != 0) {
        throw std::runtime_error("expected '" + want + " N', found: " + line);
      }
      char* stop = nullptr;
      const char* count = line.c_str() + want.size() + 1;
      const unsigned long long n = std::strtoull(count, &stop, 10);
      if (stop == count || *stop != '\0' || n > 0xFFFFFFFFull) {
        throw std::runtime_error("bad element count: " + line);
      }
      (next == 2 ? layout.vertices : layout.faces) = static_cast<size_t>(n);
    } else if (line != want) {
      throw std::runtime_error("only the layout of make_displaced_sphere_ply.py is read; found: " +
                               line);
    }
    ++next;
  }
  if (next != std::size(expected)) throw std::runtime_error("incomplete header");
  layout.body = end + std::strlen("end_header\n");
  if (file.size() != layout.body + 12 * layout.vertices + 13 * layout.faces) {
    throw std::runtime_error("file size does not match the header's element counts");
  }
  return layout;
}

// Sets FTZ/DAZ for the calling thread, as Embree's documentation recommends for speed.
void flush_denormals() {
  _mm_setcsr(_mm_getcsr() | 0x8040);
}

void fail(const std::string& subject, const std::string& reason) {
  std::fprintf(stderr, "tritrace_embree_first_frame: %s: %s\n", subject.c_str(), reason.c_str());
  std::exit(1);
}

int parse_size(const char* text, const char* name) {
  char* stop = nullptr;
  const long value = std::strtol(text, &stop, 10);
  if (stop == text || *stop != '\0' || value < 1 || value > 32768) {
    fail(name, std::string("expected an integer from 1 to 32768, got '") + text + "'");
  }
  return static_cast<int>(value);
}

}  // namespace

int main(int argc, char** argv) {
  const Clock::time_point start = Clock::now();
  if (argc != 2 && argc != 4) {
    std::fprintf(stderr, "usage: tritrace_embree_first_frame MESH.ply [WIDTH HEIGHT]\n");
    return 2;
  }
  const std::string path = argv[1];
  const int width = argc == 4 ? parse_size(argv[2], "WIDTH") : 1920;
  const int height = argc == 4 ? parse_size(argv[3], "HEIGHT") : 1080;
  flush_denormals();

  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) fail("embree", "cannot create a device");
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);

  // Geometry 0: the lab box, from the library's built-in scene.
  const tritrace::Scene box = tritrace::make_cornell_box();
  {
    const size_t n = box.mesh.size();
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_MEDIUM);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    for (size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 p = box.mesh.vertex(i, c);
        std::memcpy(vertices + 9 * i + 3 * c, &p, sizeof p);
        indices[3 * i + c] = static_cast<unsigned>(3 * i + c);
      }
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  }

  // Geometry 1: the PLY, read straight into Embree's buffers.
  const Clock::time_point load_start = Clock::now();
  size_t ply_triangles = 0;
  try {
    const MappedFile file(path);
    const PlyLayout layout = read_header(file);
    ply_triangles = layout.faces;
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_MEDIUM);
    auto* vertices = static_cast<char*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), layout.vertices));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), layout.faces));
    if (!vertices || !indices) throw std::runtime_error("cannot allocate Embree's buffers");
    const char* vertex_data = file.data() + layout.body;
    const char* face_data = vertex_data + 12 * layout.vertices;
    constexpr size_t kGrain = 1 << 16;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, layout.vertices, kGrain),
                      [&](const tbb::blocked_range<size_t>& r) {
                        std::memcpy(vertices + 12 * r.begin(), vertex_data + 12 * r.begin(),
                                    12 * r.size());
                      });
    // Each face is a count byte (3) and three little-endian int32 indices: 13 bytes, unaligned.
    const size_t bad = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, layout.faces, kGrain), size_t{0},
        [&](const tbb::blocked_range<size_t>& r, size_t errors) {
          for (size_t f = r.begin(); f < r.end(); ++f) {
            const char* p = face_data + 13 * f;
            int32_t abc[3];
            std::memcpy(abc, p + 1, sizeof abc);
            const bool ok = static_cast<unsigned char>(p[0]) == 3 && abc[0] >= 0 && abc[1] >= 0 &&
                            abc[2] >= 0 && static_cast<size_t>(abc[0]) < layout.vertices &&
                            static_cast<size_t>(abc[1]) < layout.vertices &&
                            static_cast<size_t>(abc[2]) < layout.vertices;
            errors += ok ? 0 : 1;
            for (int c = 0; c < 3; ++c) indices[3 * f + c] = static_cast<unsigned>(abc[c]);
          }
          return errors;
        },
        [](size_t a, size_t b) { return a + b; });
    if (bad > 0) {
      throw std::runtime_error(std::to_string(bad) +
                               " faces are not triangles or index a missing vertex");
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  } catch (const std::exception& e) {
    fail(path, e.what());
  }
  const double load_s = seconds_since(load_start);

  const Clock::time_point build_start = Clock::now();
  rtcCommitScene(scene);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail("embree", "building the scene failed");
  const double build_s = seconds_since(build_start);

  // One frame: one primary ray per pixel, 8 neighbouring pixels of a row per packet, rows spread
  // over every core by TBB. The hit counts are the checksum (no image is written).
  const tritrace::Camera camera =
      tritrace::Camera::look_at(width, height, {0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 0.0f},
                                {0.0f, -1.0f, 0.0f}, static_cast<float>(height));
  const Clock::time_point frame_start = Clock::now();
  const auto counts = tbb::parallel_reduce(
      tbb::blocked_range<int>(0, height, 4), std::pair<size_t, size_t>{0, 0},
      [&](const tbb::blocked_range<int>& rows, std::pair<size_t, size_t> hits) {
        flush_denormals();
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        for (int y = rows.begin(); y < rows.end(); ++y) {
          for (int x0 = 0; x0 < width; x0 += 8) {
            alignas(32) RTCRayHit8 packet;
            alignas(32) int valid[8];
            for (int k = 0; k < 8; ++k) {
              const int x = std::min(x0 + k, width - 1);
              const tritrace::Ray ray = camera.primary_ray(x, y);
              valid[k] = x0 + k < width ? -1 : 0;
              packet.ray.org_x[k] = ray.origin.x;
              packet.ray.org_y[k] = ray.origin.y;
              packet.ray.org_z[k] = ray.origin.z;
              packet.ray.dir_x[k] = ray.dir.x;
              packet.ray.dir_y[k] = ray.dir.y;
              packet.ray.dir_z[k] = ray.dir.z;
              packet.ray.tnear[k] = 0.0f;
              packet.ray.tfar[k] = INFINITY;
              packet.ray.time[k] = 0.0f;
              packet.ray.mask[k] = 0xFFFFFFFFu;
              packet.ray.id[k] = static_cast<unsigned>(k);
              packet.ray.flags[k] = 0;
              packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect8(valid, scene, &context, &packet);
            for (int k = 0; k < 8; ++k) {
              if (valid[k] == 0 || packet.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
              ++hits.first;
              if (packet.hit.geomID[k] == 1) ++hits.second;
            }
          }
        }
        return hits;
      },
      [](std::pair<size_t, size_t> a, std::pair<size_t, size_t> b) {
        return std::pair<size_t, size_t>{a.first + b.first, a.second + b.second};
      });
  const double frame_s = seconds_since(frame_start);
  const double total_s = seconds_since(start);

  rtcReleaseScene(scene);
  rtcReleaseDevice(device);

  struct rusage usage {};
  ::getrusage(RUSAGE_SELF, &usage);  // ru_maxrss is in KiB on Linux
  std::printf(
      "%s: %zu + %zu triangles, %dx%d\n"
      "load %.3f s, build %.3f s (medium quality), frame %.3f s, total %.3f s\n"
      "pixels hit %zu of %d (the mesh %zu), peak RSS %ld KiB (%.2f GiB)\n",
      path.c_str(), box.mesh.size(), ply_triangles, width, height, load_s, build_s, frame_s,
      total_s, counts.first, width * height, counts.second, usage.ru_maxrss,
      static_cast<double>(usage.ru_maxrss) / (1024.0 * 1024.0));
  return 0;
}
