// `tritrace render --mpi`: every rank loads the scene and builds the accel, rank 0 checks that
// every rank has the render identity it has, hands out units (a tile part x a sample range) to
// whichever rank asks and adds their block sums as they arrive in the block tree's fixed order,
// so the image is the one-process image bit for bit.
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

#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/merge_plan.h"
#include "tritrace/image/atomic_file.h"
#include "tritrace/job/render_job.h"
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

enum Tag : int { kReady = 1, kWork = 2, kStop = 3, kResult = 4, kPiece = 5 };

// Units: tile part t of `tiles` x sample range [first, end). Ranges are whole blocks of 8 (the
// last may end at the spp), so the merge is exact. With adaptive sampling (`whole`) a pixel decides
// from all its samples, so every unit is a tile part's whole range [0, spp). With light tracing
// (`splats`, bdpt) a unit's splats land anywhere in the image, so every unit is the whole image
// (one tile part) and the units are sample ranges only.
std::vector<PartRange> make_units(int ranks, uint32_t spp, int width, int height, bool path,
                                  bool whole, bool splats) {
  const int tile_count = ((width + kPartTileSize - 1) / kPartTileSize) *
                         ((height + kPartTileSize - 1) / kPartTileSize);
  // About four units per worker and at most four sample ranges: small enough to balance, large
  // enough that a unit's start-up (the tile's pixels, the message) stays small.
  const int workers = std::max(1, ranks - 1);
  const uint32_t chunks =
      path && !whole ? std::min<uint32_t>(4, (spp + kSampleBlock - 1) / kSampleBlock) : 1;
  const int tiles = splats ? 1 : std::clamp(4 * workers / static_cast<int>(chunks), 1, tile_count);
  uint32_t chunk = (spp + chunks - 1) / chunks;
  chunk = (chunk + kSampleBlock - 1) / kSampleBlock * kSampleBlock;
  std::vector<PartRange> units;
  for (int t = 0; t < tiles; ++t) {
    for (uint32_t a = 0; a < spp; a += chunk)
      units.push_back({a, std::min(spp, a + chunk), t, tiles});
  }
  return units;
}

size_t floats_per_pixel(const AovSet& aovs) {
  return 4 + (aovs.any() ? 7 : 0) + (aovs.variance ? 4 : 0) + (aovs.spp ? 1 : 0);
}

// A unit's packed film (pack_part) as floats: per layer the unit's pixels' (R, G, B, W), then
// their AOV sums; the packed film's padding is not sent.
std::vector<float> pack(const Film& packed, size_t pixels) {
  std::vector<float> out;
  const bool aovs = packed.aovs().any();
  out.reserve(packed.layer_count() * pixels * floats_per_pixel(packed.aovs()));
  for (size_t k = 0; k < packed.layer_count(); ++k) {
    const glm::vec4* sums = packed.sums(k);
    for (size_t p = 0; p < pixels; ++p) {
      out.insert(out.end(), {sums[p].x, sums[p].y, sums[p].z, sums[p].w});
    }
    if (aovs) {
      const AovSums* a = packed.aov_sums(k);
      for (size_t p = 0; p < pixels; ++p) {
        out.insert(out.end(), {a[p].albedo.x, a[p].albedo.y, a[p].albedo.z, a[p].normal.x,
                               a[p].normal.y, a[p].normal.z, a[p].depth});
        if (packed.aovs().variance) {
          out.insert(out.end(), {a[p].even.x, a[p].even.y, a[p].even.z, a[p].even.w});
        }
        if (packed.aovs().spp) out.push_back(a[p].samples);
      }
    }
  }
  if (packed.has_splats()) {
    // The light image's 64-bit integers, word for word in the floats' bytes (a whole-image unit:
    // no padding).
    const std::vector<uint64_t>& words = packed.splats().data();
    const size_t at = out.size();
    out.resize(at + 2 * words.size());
    std::memcpy(out.data() + at, words.data(), words.size() * sizeof(uint64_t));
  }
  return out;
}

// The floats a unit's light image takes (6 per pixel) when the render splats.
size_t splat_floats(bool splats, size_t pixels) {
  return splats ? 6 * pixels : 0;
}

// The layers a unit of samples [first, end) sends.
size_t unit_layers(const PartRange& unit) {
  BlockCounter counter;
  counter.push_blocks(unit.first / kSampleBlock, unit.end / kSampleBlock);
  return counter.size() + (unit.end % kSampleBlock != 0 ? 1 : 0);
}

Film unpack(const std::vector<float>& data, const RenderIdentity& r, const PartRange& unit,
            bool splats) {
  const PackedShape shape = packed_shape(r.width, r.height, unit.tile, unit.tiles);
  Film film(shape.width, shape.height, r.aovs);
  BlockCounter counter;
  counter.push_blocks(unit.first / kSampleBlock, unit.end / kSampleBlock);
  film.set_layout(unit.first, unit.end,
                  std::vector<BlockNode>(counter.nodes().begin(), counter.nodes().end()));
  const bool aovs = r.aovs.any();
  size_t i = 0;
  for (size_t k = 0; k < film.layer_count(); ++k) {
    glm::vec4* sums = film.sums(k);
    for (size_t p = 0; p < shape.pixels; ++p, i += 4) {
      sums[p] = glm::vec4(data[i], data[i + 1], data[i + 2], data[i + 3]);
    }
    if (aovs) {
      AovSums* a = film.aov_sums(k);
      for (size_t p = 0; p < shape.pixels; ++p, i += 7) {
        a[p] = {glm::vec3(data[i], data[i + 1], data[i + 2]),
                glm::vec3(data[i + 3], data[i + 4], data[i + 5]), data[i + 6]};
        if (r.aovs.variance) {
          a[p].even = glm::vec4(data[i + 7], data[i + 8], data[i + 9], data[i + 10]);
          i += 4;
        }
        if (r.aovs.spp) {
          a[p].samples = data[i + 7];
          i += 1;
        }
      }
    }
  }
  if (splats) {
    film.enable_splats();
    std::vector<uint64_t>& words = film.splats().data();
    std::memcpy(words.data(), data.data() + i, words.size() * sizeof(uint64_t));
  }
  return film;
}

// MPI counts are ints, so a message of 2^31 bytes or more cannot be sent at once: a unit's sums
// go in pieces of at most this many bytes. TRITRACE_MPI_TEST_PIECE_BYTES lowers it, for the test
// that small images still arrive whole when cut into many pieces.
size_t piece_bytes() {
  size_t bytes = size_t{1} << 30;
  if (const char* text = std::getenv("TRITRACE_MPI_TEST_PIECE_BYTES")) {
    const long long v = std::atoll(text);
    if (v > 0) bytes = static_cast<size_t>(v);
  }
  return bytes;
}

// A result is a head (unit index, float count, camera samples taken) followed by the floats' bytes
// in pieces. The samples add up to the render's mean spp under adaptive sampling.
void send_result(uint64_t unit, const std::vector<float>& data, uint64_t samples, size_t piece) {
  const uint64_t head[3] = {unit, data.size(), samples};
  MPI_Send(head, 3, MPI_UINT64_T, 0, kResult, MPI_COMM_WORLD);
  const char* bytes = reinterpret_cast<const char*>(data.data());
  const size_t total = data.size() * sizeof(float);
  for (size_t at = 0; at < total; at += piece) {
    MPI_Send(bytes + at, static_cast<int>(std::min(piece, total - at)), MPI_BYTE, 0, kPiece,
             MPI_COMM_WORLD);
  }
}

// The pieces of a result whose head said `count` floats; false when a piece overruns it. MPI
// keeps one sender's messages in order, so the pieces are this result's.
bool receive_pieces(int from, std::vector<float>& data) {
  char* bytes = reinterpret_cast<char*>(data.data());
  const size_t total = data.size() * sizeof(float);
  for (size_t at = 0; at < total;) {
    MPI_Status status;
    MPI_Probe(from, kPiece, MPI_COMM_WORLD, &status);
    int n = 0;
    MPI_Get_count(&status, MPI_BYTE, &n);
    if (n <= 0 || static_cast<size_t>(n) > total - at) return false;
    MPI_Recv(bytes + at, n, MPI_BYTE, from, kPiece, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    at += static_cast<size_t>(n);
  }
  return true;
}

// Every rank makes the render job `tritrace render` makes, and times its start-up.
struct RankSetup {
  std::unique_ptr<RenderJob> job;
  RenderIdentity identity;
  double startup_ms = 0.0;
};

void setup(const RenderArgs& args, RankSetup& s) {
  const auto start = std::chrono::steady_clock::now();
  s.job = std::make_unique<RenderJob>(args.job, load_job_scene(args.job));
  s.job->prepare();
  s.identity = s.job->identity();
  s.startup_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

[[noreturn]] void abort_job(int rank, const std::string& message) {
  std::fprintf(stderr, "tritrace: rank %d: %s\n", rank, message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::exit(1);
}

// Renders a unit of the job into an image-sized film and keeps only the unit's pixels; adds the
// camera samples it took to `samples`.
Film render_unit(const RankSetup& s, const PartRange& u, uint64_t& samples) {
  RenderOptions options = s.job->options();
  options.first_sample = u.first;
  options.spp = u.end - u.first;
  options.tile_part = u.tile;
  options.tile_parts = u.tiles;
  Film film = s.job->make_film();
  RenderStats stats;
  s.job->render_to_film(film, options, &stats);
  samples += stats.samples;
  return pack_part(film, u.tile, u.tiles);
}

void work(int rank, const RankSetup& s, const std::vector<PartRange>& units) {
  // For the test of a dying rank: TRITRACE_MPI_TEST_DIE=R makes rank R die on its first unit, as
  // a process killed by the system (out of memory, a node lost) would. mpirun then ends the job
  // and names the rank ("process rank R with PID ... exited on signal 9").
  const char* die = std::getenv("TRITRACE_MPI_TEST_DIE");
  const bool must_die = die && std::atoi(die) == rank;
  const size_t piece = piece_bytes();
  MPI_Send(nullptr, 0, MPI_BYTE, 0, kReady, MPI_COMM_WORLD);
  while (true) {
    int unit = 0;
    MPI_Status status;
    MPI_Recv(&unit, 1, MPI_INT, 0, MPI_ANY_TAG, MPI_COMM_WORLD, &status);
    if (status.MPI_TAG == kStop) return;
    if (must_die) std::raise(SIGKILL);
    const PartRange& u = units[static_cast<size_t>(unit)];
    uint64_t samples = 0;
    const Film packed = render_unit(s, u, samples);
    const PackedShape shape = packed_shape(s.identity.width, s.identity.height, u.tile, u.tiles);
    send_result(static_cast<uint64_t>(unit), pack(packed, shape.pixels), samples, piece);
  }
}

// The identity as one text (hash, settings, build, AOVs, host) for the check against rank 0's.
std::string identity_text(const RenderIdentity& id) {
  char host[MPI_MAX_PROCESSOR_NAME] = {};
  int length = 0;
  MPI_Get_processor_name(host, &length);
  return id.hash + "\n" + id.settings + "\n" + id.build + "\n" + aov_list(id.aovs) + "\n" +
         std::string(host, static_cast<size_t>(length));
}

// Every rank's identity must be rank 0's before anything is rendered: a rank that loaded another
// scene file (a different copy on its node) or runs another build would otherwise merge sums of
// another render into the image. Rank 0 names the first rank that differs, its host and how.
void check_identities(int rank, int ranks, const RenderIdentity& own) {
  const std::string text = identity_text(own);
  const int length = static_cast<int>(text.size());
  std::vector<int> lengths(rank == 0 ? static_cast<size_t>(ranks) : 0);
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> offsets(lengths.size());
  std::string all;
  if (rank == 0) {
    for (size_t r = 1; r < lengths.size(); ++r) offsets[r] = offsets[r - 1] + lengths[r - 1];
    all.resize(static_cast<size_t>(offsets.back() + lengths.back()));
  }
  MPI_Gatherv(text.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(), MPI_CHAR,
              0, MPI_COMM_WORLD);
  if (rank != 0) return;
  for (int r = 1; r < ranks; ++r) {
    const std::string other =
        all.substr(static_cast<size_t>(offsets[r]), static_cast<size_t>(lengths[r]));
    if (other == text) continue;
    auto field = [&](int k) {  // line k of `other`
      size_t at = 0;
      for (int i = 0; i < k; ++i) at = other.find('\n', at) + 1;
      return other.substr(at, other.find('\n', at) - at);
    };
    RenderIdentity theirs = own;
    theirs.hash = field(0);
    theirs.settings = field(1);
    theirs.build = field(2);
    const std::string aovs = field(3);
    std::string why;
    theirs.aovs = aovs.empty() ? AovSet{} : parse_aovs(aovs, &why).value_or(AovSet{});
    const std::string difference = identity_difference(theirs, own);
    if (difference.empty()) continue;  // only the host differs
    std::fprintf(stderr, "tritrace: rank %d (host %s) differs from rank 0: %s\n", r,
                 field(4).c_str(), difference.c_str());
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, 1);
    std::exit(1);
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
      if (!args.job.output_given) {
        throw Error("--mpi", "needs -o OUT (the one file rank 0 writes)", ExitCode::kUsage);
      }
      RenderJob::check_output(args.job, args.job.output);
      check_writable_path(args.job.output);
    }
    setup(args, s);
  } catch (const Error& e) {
    abort_job(rank, e.what());
  }
  check_identities(rank, ranks, s.identity);
  const bool path = s.job->path();
  const std::vector<PartRange> units =
      make_units(ranks, path ? s.job->spec().spp : 1, s.identity.width, s.identity.height, path,
                 s.job->options().noise_threshold > 0.0f, s.job->integrator().splats());

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

  // Rank 0 adds each unit into the output film as it arrives. A tile part's sample ranges must be
  // added in sample order (float addition is not associative), so a range that arrives before
  // the one ending where it starts is held until then; units are handed out in that order, so
  // few are ever held.
  FilmMerger merger(s.identity, units.front().tiles);
  uint64_t samples = 0;  // camera samples taken by every unit, for the mean spp
  std::vector<bool> received(units.size(), false);
  try {
    std::vector<PartInfo> infos;
    std::vector<std::string> names;
    for (size_t u = 0; u < units.size(); ++u) {
      infos.push_back({s.identity, units[u]});
      names.push_back("unit " + std::to_string(u));
    }
    (void)plan_merge(names, infos);
    if (ranks == 1) {
      // No worker: rank 0 renders every unit itself.
      for (const PartRange& u : units) merger.add(u, render_unit(s, u, samples));
    }
  } catch (const Error& e) {
    abort_job(0, e.what());
  }
  size_t next = 0;
  int stopped = 0;
  while (stopped < ranks - 1) {
    MPI_Status status;
    MPI_Probe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &status);
    const int from = status.MPI_SOURCE;
    if (status.MPI_TAG == kResult) {
      uint64_t head[3] = {0, 0, 0};
      MPI_Recv(head, 3, MPI_UINT64_T, from, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      const uint64_t u = head[0];
      const std::string sender = "rank " + std::to_string(from);
      if (u >= units.size() || received[u]) abort_job(0, sender + " sent an unknown unit");
      const PackedShape shape =
          packed_shape(s.identity.width, s.identity.height, units[u].tile, units[u].tiles);
      const bool splats = s.job->integrator().splats();
      if (head[1] != unit_layers(units[u]) * shape.pixels * floats_per_pixel(s.identity.aovs) +
                         splat_floats(splats, shape.pixels)) {
        abort_job(0, sender + " sent a unit of the wrong size");
      }
      std::vector<float> data(head[1]);
      if (!receive_pieces(from, data)) abort_job(0, sender + " sent a unit of the wrong size");
      received[u] = true;
      samples += head[2];
      try {
        merger.add(units[u], unpack(data, s.identity, units[u], splats));
      } catch (const Error& e) {
        abort_job(0, sender + ": " + e.what());
      }
    } else if (status.MPI_TAG == kReady) {
      MPI_Recv(nullptr, 0, MPI_BYTE, from, kReady, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    } else {
      abort_job(0, "rank " + std::to_string(from) + " sent an unexpected message");
    }
    if (next < units.size()) {
      const int u = static_cast<int>(next++);
      MPI_Send(&u, 1, MPI_INT, from, kWork, MPI_COMM_WORLD);
    } else {
      MPI_Send(nullptr, 0, MPI_INT, from, kStop, MPI_COMM_WORLD);
      ++stopped;
    }
  }

  const size_t most_held = merger.most_held();
  // The whole job's time (start-up, rendering and gathering on every rank), as the EXR records it.
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  try {
    const Film film = std::move(merger).finish();
    RenderStats stats;
    stats.milliseconds = ms;
    stats.samples = samples;
    stats.pixels =
        static_cast<uint64_t>(s.identity.width) * static_cast<uint64_t>(s.identity.height);
    stats.spp = s.identity.spp;
    s.job->write(film, args.job.output, stats);
  } catch (const Error& e) {
    abort_job(0, e.what());
  }
  if (!args.quiet) {
    std::printf(
        "rendered %dx%d, %u spp on %d rank%s (%zu units, at most %zu held for merging, start-up "
        "up to %.1f ms) in %.1f ms to %s\n",
        s.identity.width, s.identity.height, s.identity.spp, ranks, ranks == 1 ? "" : "s",
        units.size(), most_held, slowest_startup, ms, args.job.output.c_str());
  }
  MPI_Finalize();
  return 0;
}

#endif

}  // namespace tritrace::cli
