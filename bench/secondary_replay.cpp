// tritrace_secondary_replay: one accel's half of `tritrace bench --secondary-rays`, for profilers.
// The path tracer's frame (256 x 256, SPP samples, one thread) is rendered once through the BVH
// with its incoherent rays recorded, and cached in RAYS_FILE (read instead when it exists); then
// only ACCEL's closest-hit (intersect_incoherent) or any-hit (occluded_incoherent) queries are
// replayed REPS times in the frame's batches, so that perf or callgrind sees that work alone.
// Prints each pass's CPU ms, their median, and how many answers differ from the recorded ones.
//
// The rays go with the triangles they leave, as the path tracer gives them (an accel may skip the
// convex mesh a ray leaves); with a last argument `no-origins` without them, so that the answers
// with and without can be compared (the recorded ones are the BVH's with them).
//
//   tritrace_secondary_replay SCENE_FILE|BUILTIN SPP RAYS_FILE REPS closest|any ACCEL [no-origins]
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/accel/recording_accel.h"
#include "tritrace/job/render_job.h"

namespace {

using namespace tritrace;

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

template <typename T>
void write_vector(std::ofstream& out, const std::vector<T>& v) {
  const uint64_t n = v.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}

template <typename T>
void read_vector(std::ifstream& in, std::vector<T>& v) {
  uint64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  v.resize(n);
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}

void save(const std::string& path, const RecordedRays& r) {
  std::ofstream out(path, std::ios::binary);
  write_vector(out, r.closest.rays);
  write_vector(out, r.closest.sizes);
  write_vector(out, r.closest.groups);
  write_vector(out, r.hits);
  write_vector(out, r.any.rays);
  write_vector(out, r.any.sizes);
  write_vector(out, r.any.groups);
  write_vector(out, r.occluded);
  write_vector(out, r.closest.origins);
  write_vector(out, r.any.origins);
}

RecordedRays load(const std::string& path) {
  RecordedRays r;
  std::ifstream in(path, std::ios::binary);
  read_vector(in, r.closest.rays);
  read_vector(in, r.closest.sizes);
  read_vector(in, r.closest.groups);
  read_vector(in, r.hits);
  read_vector(in, r.any.rays);
  read_vector(in, r.any.sizes);
  read_vector(in, r.any.groups);
  read_vector(in, r.occluded);
  // Files written before the origins were recorded end here: their rays replay without them.
  if (in.peek() != std::char_traits<char>::eof()) {
    read_vector(in, r.closest.origins);
    read_vector(in, r.any.origins);
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 7 && !(argc == 8 && std::string(argv[7]) == "no-origins")) {
    std::fprintf(stderr,
                 "usage: tritrace_secondary_replay SCENE_FILE|BUILTIN SPP RAYS_FILE REPS "
                 "closest|any ACCEL [no-origins]\n");
    return 2;
  }
  try {
    const std::string source = argv[1];
    JobSettings settings;
    if (std::filesystem::exists(source)) {
      settings.file = source;
    } else {
      settings.scene = source;
    }
    settings.width = "256";
    settings.height = "256";
    settings.threads = "1";
    settings.integrator = "path";
    settings.spp = argv[2];
    settings.accel = "bvh";
    settings.bvh_build = "sah";
    const LoadedScene loaded = load_job_scene(settings);
    const Scene& scene = loaded.scene;
    const AccelKind kind = parse_accel(argv[6]).value_or(AccelKind::kBvh);
    const std::unique_ptr<Accel> accel =
        make_accel(kind, scene, default_kernel_for(kind), nullptr, bvh::BuildMethod::kBinnedSah);
    const std::string rays_file = argv[3];
    RecordedRays recorded;
    if (std::filesystem::exists(rays_file)) {
      recorded = load(rays_file);
    } else {
      const std::unique_ptr<Accel> bvh =
          make_accel(AccelKind::kBvh, scene, default_kernel_for(AccelKind::kBvh), nullptr,
                     bvh::BuildMethod::kBinnedSah);
      RecordingAccel recording(*bvh, GroupOrder::kCallOrder);
      RenderJob job(settings, scene, loaded.integrator);
      job.prepare(nullptr, &recording);
      RenderStats stats;
      job.render(&stats);
      recorded = recording.take();
      save(rays_file, recorded);
    }
    if (argc == 8) {
      recorded.closest.origins.clear();
      recorded.any.origins.clear();
    }
    const int reps = std::max(1, std::stoi(argv[4]));
    const bool closest = std::string(argv[5]) == "closest";
    std::vector<Hit> hits(recorded.hits.size());
    std::vector<uint8_t> occluded(recorded.occluded.size());
    std::vector<double> ms;
    for (int i = 0; i <= reps; ++i) {
      const double start = cpu_ms();
      if (closest) {
        replay_closest(*accel, recorded.closest, hits, 1);
      } else {
        replay_any(*accel, recorded.any, occluded, 1);
      }
      if (i > 0) ms.push_back(cpu_ms() - start);
    }
    size_t differ = 0;
    if (closest) {
      for (size_t i = 0; i < hits.size(); ++i)
        differ += std::memcmp(&hits[i], &recorded.hits[i], sizeof(Hit)) != 0;
    } else {
      for (size_t i = 0; i < occluded.size(); ++i)
        differ += (occluded[i] != 0) != (recorded.occluded[i] != 0);
    }
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    std::printf("%s %s %s: %zu rays in %zu batches, cpu ms median %.2f (", argv[1], argv[5],
                argv[6], closest ? hits.size() : occluded.size(),
                closest ? recorded.closest.sizes.size() : recorded.any.sizes.size(),
                sorted[sorted.size() / 2]);
    for (const double m : ms) std::printf(" %.1f", m);
    std::printf(" ), %zu not bit for bit the recorded\n", differ);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tritrace_secondary_replay: %s\n", e.what());
    return 1;
  }
  return 0;
}
