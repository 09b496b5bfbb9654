// `tritrace render --mpi`: every rank loads the scene and builds the accel, rank 0 hands out units
// (a tile part x a sample range) to whichever rank asks, gathers their block sums and merges them
// in the block tree's fixed order, so the image is the one-process image bit for bit.
#include <cstdio>
#include <cstdlib>

#include "render_command.h"
#include "tritrace/error.h"

#if TRITRACE_HAVE_MPI
#include <mpi.h>
#include <unistd.h>

#include <csignal>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <vector>

#include "flags/flag_values.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/partial_film.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/image/image_io.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_loader.h"
#endif

namespace tritrace::cli {

#if !TRITRACE_HAVE_MPI

int run_render_mpi(const RenderArgs&) {
  throw Error("--mpi",
              "this tritrace was built without MPI (configure with -DTRITRACE_WITH_MPI=ON and "
              "Open MPI installed: scripts/install-deps.sh)",
              ExitCode::kUsage);
}

#else

namespace {

enum Tag : int { kReady = 1, kWork = 2, kStop = 3, kResult = 4 };

// Units: tile part t of `tiles` x sample range [first, end). Ranges are whole blocks of 8 (the
// last may end at the spp), so the merge is exact.
std::vector<PartRange> make_units(int ranks, uint32_t spp, int width, int height, bool path) {
  const int tile_count = ((width + kPartTileSize - 1) / kPartTileSize) *
                         ((height + kPartTileSize - 1) / kPartTileSize);
  // About four units per worker and at most four sample ranges: small enough to balance, large
  // enough that a unit's start-up (the tile's pixels, the message) stays small.
  const int workers = std::max(1, ranks - 1);
  const uint32_t chunks = path ? std::min<uint32_t>(4, (spp + kSampleBlock - 1) / kSampleBlock) : 1;
  const int tiles = std::clamp(4 * workers / static_cast<int>(chunks), 1, tile_count);
  uint32_t chunk = (spp + chunks - 1) / chunks;
  chunk = (chunk + kSampleBlock - 1) / kSampleBlock * kSampleBlock;
  std::vector<PartRange> units;
  for (int t = 0; t < tiles; ++t) {
    for (uint32_t a = 0; a < spp; a += chunk)
      units.push_back({a, std::min(spp, a + chunk), t, tiles});
  }
  return units;
}

// A unit's sums as floats: per layer the group's pixels' (R, G, B, W), then their AOV sums.
std::vector<float> pack(const Film& film, const std::vector<size_t>& pixels) {
  std::vector<float> out;
  const bool aovs = film.aovs().any();
  out.reserve(film.layer_count() * pixels.size() * (aovs ? 11 : 4));
  for (size_t k = 0; k < film.layer_count(); ++k) {
    const glm::vec4* sums = film.sums(k);
    for (size_t p : pixels) out.insert(out.end(), {sums[p].x, sums[p].y, sums[p].z, sums[p].w});
    if (aovs) {
      const AovSums* a = film.aov_sums(k);
      for (size_t p : pixels) {
        out.insert(out.end(), {a[p].albedo.x, a[p].albedo.y, a[p].albedo.z, a[p].normal.x,
                               a[p].normal.y, a[p].normal.z, a[p].depth});
      }
    }
  }
  return out;
}

Film unpack(const std::vector<float>& data, const RenderIdentity& r, const PartRange& unit,
            const std::vector<size_t>& pixels) {
  Film film(r.width, r.height, r.aovs);
  BlockCounter counter;
  counter.push_blocks(unit.first / kSampleBlock, unit.end / kSampleBlock);
  film.set_layout(unit.first, unit.end,
                  std::vector<BlockNode>(counter.nodes().begin(), counter.nodes().end()));
  const bool aovs = r.aovs.any();
  if (data.size() != film.layer_count() * pixels.size() * (aovs ? 11 : 4)) {
    throw Error("--mpi", "a rank sent a unit of the wrong size");
  }
  size_t i = 0;
  for (size_t k = 0; k < film.layer_count(); ++k) {
    glm::vec4* sums = film.sums(k);
    for (size_t p : pixels) {
      sums[p] = glm::vec4(data[i], data[i + 1], data[i + 2], data[i + 3]);
      i += 4;
    }
    if (aovs) {
      AovSums* a = film.aov_sums(k);
      for (size_t p : pixels) {
        a[p] = {glm::vec3(data[i], data[i + 1], data[i + 2]),
                glm::vec3(data[i + 3], data[i + 4], data[i + 5]), data[i + 6]};
        i += 7;
      }
    }
  }
  return film;
}

// Everything a rank needs to render units, loaded and built the way `tritrace render` does.
struct RankSetup {
  RankSetup() = default;
  RankSetup(const RankSetup&) = delete;
  RankSetup& operator=(const RankSetup&) = delete;

  LoadedScene loaded;
  IntegratorSpec spec;
  RenderOptions options;
  std::unique_ptr<Accel> accel;
  std::unique_ptr<Integrator> integrator;
  AovSet aovs;
  RenderIdentity identity;
  double startup_ms = 0.0;
};

AovSet aovs_of(const std::string& text) {
  AovSet set;
  set.albedo = text.find("albedo") != std::string::npos;
  set.normal = text.find("normal") != std::string::npos;
  set.depth = text.find("depth") != std::string::npos;
  return set;
}

// Fills `s` in place: the accel and integrator keep references into s.loaded.scene, so the setup
// must never be moved or copied afterwards.
void setup(const RenderArgs& args, RankSetup& s) {
  const auto start = std::chrono::steady_clock::now();
  s.loaded = load_scene_from(args.scene, scene_overrides(args.scene));
  const Scene& scene = s.loaded.scene;
  s.spec = integrator_spec(args.scene, s.loaded);
  s.options.threads = thread_count(args.scene);
  s.options.spp = s.spec.spp;
  s.options.seed = s.spec.seed;
  s.options.sampler = s.spec.sampler;
  s.options.filter = filter_choice(args.scene);
  const AccelKind accel = accel_kind(args.scene);
  const Kernel kernel = kernel_choice(args.scene);
  s.accel =
      make_accel(accel, scene, kernel, nullptr,
                 bvh_build_choice(args.scene, scene.stored_triangles(), s.spec, scene.camera));
  s.integrator = make_integrator(s.spec, scene);
  s.aovs = aovs_of(args.aovs);
  s.identity =
      render_identity(scene, s.spec, s.options, accel_name(accel), kernel_name(kernel), s.aovs);
  s.startup_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

[[noreturn]] void abort_job(int rank, const std::string& message) {
  std::fprintf(stderr, "tritrace: rank %d: %s\n", rank, message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::exit(1);
}

void work(int rank, const RankSetup& s, const std::vector<PartRange>& units) {
  // For the test of a dying rank: TRITRACE_MPI_TEST_DIE=R makes rank R die on its first unit, as
  // a process killed by the system (out of memory, a node lost) would. mpirun then ends the job
  // and names the rank ("process rank R with PID ... exited on signal 9").
  const char* die = std::getenv("TRITRACE_MPI_TEST_DIE");
  const bool must_die = die && std::atoi(die) == rank;
  MPI_Send(nullptr, 0, MPI_BYTE, 0, kReady, MPI_COMM_WORLD);
  while (true) {
    int unit = 0;
    MPI_Status status;
    MPI_Recv(&unit, 1, MPI_INT, 0, MPI_ANY_TAG, MPI_COMM_WORLD, &status);
    if (status.MPI_TAG == kStop) return;
    if (must_die) std::raise(SIGKILL);
    const PartRange& u = units[static_cast<size_t>(unit)];
    RenderOptions options = s.options;
    options.first_sample = u.first;
    options.spp = u.end - u.first;
    options.tile_part = u.tile;
    options.tile_parts = u.tiles;
    Film film(s.identity.width, s.identity.height, s.aovs);
    render_to_film(s.loaded.scene, *s.accel, *s.integrator, film, options);
    std::vector<float> data =
        pack(film, tile_group_pixels(s.identity.width, s.identity.height, u.tile, u.tiles));
    data.insert(data.begin(), static_cast<float>(unit));  // exact for any unit count below 2^24
    MPI_Send(data.data(), static_cast<int>(data.size()), MPI_FLOAT, 0, kResult, MPI_COMM_WORLD);
  }
}

}  // namespace

int run_render_mpi(const RenderArgs& args) {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  const auto start = std::chrono::steady_clock::now();

  RankSetup s;
  std::string output;
  try {
    if (rank == 0) {
      if (!args.output_given) {
        throw Error("--mpi", "needs -o OUT (the one file rank 0 writes)", ExitCode::kUsage);
      }
      const auto format = image_format_for(args.output);
      if (!format) throw Error("--output", "'" + args.output + "' has an unknown extension");
      if (!args.aovs.empty() && *format != ImageFormat::kExr) {
        throw Error("--aovs", "needs an .exr output, got '" + args.output + "'", ExitCode::kUsage);
      }
      check_writable_path(args.output);
    }
    setup(args, s);
  } catch (const Error& e) {
    abort_job(rank, e.what());
  }
  const bool path = s.spec.kind == IntegratorSpec::Kind::kPath;
  const std::vector<PartRange> units =
      make_units(ranks, path ? s.spec.spp : 1, s.identity.width, s.identity.height, path);

  // Every rank's start-up time, for the summary (rank 0 prints the slowest).
  double slowest_startup = 0.0;
  MPI_Reduce(&s.startup_ms, &slowest_startup, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);

  if (rank != 0) {
    try {
      work(rank, s, units);
    } catch (const std::exception& e) {
      abort_job(rank, e.what());
    }
    MPI_Finalize();
    return 0;
  }

  std::vector<std::vector<float> > results(units.size());
  std::vector<int> rendered_by(units.size(), 0);
  size_t next = 0, received = 0;
  int stopped = 0;
  if (ranks == 1) {
    // No worker: rank 0 renders every unit itself.
    for (size_t u = 0; u < units.size(); ++u) {
      RenderOptions options = s.options;
      options.first_sample = units[u].first;
      options.spp = units[u].end - units[u].first;
      options.tile_part = units[u].tile;
      options.tile_parts = units[u].tiles;
      Film film(s.identity.width, s.identity.height, s.aovs);
      render_to_film(s.loaded.scene, *s.accel, *s.integrator, film, options);
      results[u] = pack(film, tile_group_pixels(s.identity.width, s.identity.height, units[u].tile,
                                                units[u].tiles));
    }
    received = units.size();
  }
  while (stopped < ranks - 1) {
    MPI_Status status;
    MPI_Probe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &status);
    const int from = status.MPI_SOURCE;
    if (status.MPI_TAG == kResult) {
      int count = 0;
      MPI_Get_count(&status, MPI_FLOAT, &count);
      std::vector<float> data(static_cast<size_t>(count));
      MPI_Recv(data.data(), count, MPI_FLOAT, from, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      const size_t u = data.empty() ? units.size() : static_cast<size_t>(data[0]);
      if (u >= units.size() || !results[u].empty())
        abort_job(0, "rank " + std::to_string(from) + " sent an unknown unit");
      results[u].assign(data.begin() + 1, data.end());
      rendered_by[u] = from;
      ++received;
    } else {
      MPI_Recv(nullptr, 0, MPI_BYTE, from, kReady, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    if (next < units.size()) {
      const int u = static_cast<int>(next++);
      MPI_Send(&u, 1, MPI_INT, from, kWork, MPI_COMM_WORLD);
    } else {
      MPI_Send(nullptr, 0, MPI_INT, from, kStop, MPI_COMM_WORLD);
      ++stopped;
    }
  }

  try {
    std::vector<PartInfo> infos;
    std::vector<std::string> names;
    for (size_t u = 0; u < units.size(); ++u) {
      infos.push_back({s.identity, units[u]});
      names.push_back("unit " + std::to_string(u) + " (rank " + std::to_string(rendered_by[u]) +
                      ")");
    }
    const std::vector<size_t> order = plan_merge(names, infos);
    const Film film = merge_planned(infos, order, [&](size_t u) {
      return unpack(
          results[u], s.identity, units[u],
          tile_group_pixels(s.identity.width, s.identity.height, units[u].tile, units[u].tiles));
    });
    const Image image = film.resolve();
    if (*image_format_for(args.output) == ImageFormat::kExr) {
      write_exr(image, args.output,
                {film.resolve_albedo(), film.resolve_normal(), film.resolve_depth()},
                args.exr_half ? ExrPixelType::kHalf : ExrPixelType::kFloat);
    } else {
      const float stops = args.exposure.empty() ? 0.0f : *parse_float(args.exposure);
      write_image(image, args.output, path ? ImageEncoding::srgb(stops) : ImageEncoding::lab());
    }
  } catch (const Error& e) {
    abort_job(0, e.what());
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!args.quiet) {
    std::printf(
        "rendered %dx%d, %u spp on %d rank%s (%zu units, start-up up to %.1f ms) in %.1f ms to "
        "%s\n",
        s.identity.width, s.identity.height, s.identity.spp, ranks, ranks == 1 ? "" : "s",
        units.size(), slowest_startup, ms, args.output.c_str());
  }
  MPI_Finalize();
  return 0;
}

#endif

}  // namespace tritrace::cli
