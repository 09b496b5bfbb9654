// `--integrator bdpt` through the render job (every front end's set-up): the job's image is the
// renderer's with BdptIntegrator called directly, sample-range parts add up to the whole film
// bit for bit (light tracing's splats included, through partial films and the merge), scene
// files ask for it by name, --noise-threshold's passes are its one render, and what bdpt cannot
// do (--clamp; with light tracing --tile, other filters) is refused as a usage error rather than
// rendered wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/distributed/film_merger.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/bdpt_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/scene_file.h"
#include "tritrace/scene/io/scene_loader.h"

namespace tritrace {
namespace {

template <typename F>
Error error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no Error thrown";
  return Error("", "");
}

// (All cores: the image does not depend on the thread count. Assigning "2" to threads here trips
// GCC 12's -Wrestrict false positive in std::string.)
JobSettings small_bdpt(const std::string& scene, const std::string& spp = "4") {
  JobSettings s;
  s.scene = scene;
  s.integrator = "bdpt";
  s.spp = spp;
  s.width = "24";
  s.height = "16";
  return s;
}

bool same_pixels(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() &&
         std::memcmp(a.pixels().data(), b.pixels().data(), a.pixels().size() * sizeof(glm::vec3)) ==
             0;
}

TEST(BdptJob, RendersWhatTheRendererRendersWithBdptDirectly) {
  for (const char* scene : {"cornell", "cornell-area"}) {
    const JobSettings s = small_bdpt(scene);
    RenderJob job(s, load_job_scene(s));
    EXPECT_EQ(job.spec().kind, IntegratorSpec::Kind::kBdpt);
    EXPECT_TRUE(job.path());  // physically based: sRGB output, many samples
    job.prepare();
    const RenderedImage got = job.render();

    const LoadedScene loaded = load_job_scene(s);
    const auto accel = make_accel(AccelKind::kBvh, loaded.scene, Kernel::kWatertight);
    // bdpt's default share is `auto`'s: the pilot's choice (LightPathsAuto... tests it).
    ASSERT_TRUE(job.light_paths_pilot().has_value()) << scene;
    const BdptIntegrator integrator(loaded.scene, {.light_paths = job.light_paths()});
    const Image want = render(loaded.scene, *accel, integrator, {.threads = 1, .spp = 4});
    EXPECT_TRUE(same_pixels(got.image, want)) << scene;
  }
}

TEST(BdptJob, IdentityNamesBdpt) {
  JobSettings s = small_bdpt("cornell-area");
  const RenderJob bdpt(s, load_job_scene(s));
  s.integrator = "path";
  const RenderJob path(s, load_job_scene(s));
  EXPECT_EQ(bdpt.identity().integrator, "bdpt");
  EXPECT_FALSE(bdpt.identity() == path.identity());  // parts of the two never merge
}

// Films of sample ranges rendered apart continue into the film of one render, bit for bit (the
// light image's integer sums included).
TEST(BdptJob, SampleRangesAddUpToTheWholeFilm) {
  SceneOverrides size;
  size.width = 20;
  size.height = 12;
  const LoadedScene loaded = load_builtin_scene("cornell-area", size);
  const auto accel = make_accel(AccelKind::kBvh, loaded.scene, Kernel::kWatertight);
  const BdptIntegrator bdpt(loaded.scene);
  Film whole(20, 12), parts(20, 12);
  render_to_film(loaded.scene, *accel, bdpt, whole, {.spp = 19, .seed = 5});
  for (uint32_t at = 0; at < 19; at += 8) {
    render_to_film(loaded.scene, *accel, bdpt, parts,
                   {.spp = std::min(8u, 19 - at), .first_sample = at, .seed = 5});
  }
  EXPECT_TRUE(same_pixels(whole.resolve(), parts.resolve()));
}

TEST(BdptJob, RefusesClampAsAUsageError) {
  JobSettings s = small_bdpt("cornell-area");
  s.clamp = "2.5";
  const Error e = error_of([&] { RenderJob(s, load_job_scene(s)); });
  EXPECT_EQ(e.subject(), "--clamp");
  EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
  // An environment map is rendered.
  JobSettings sky = small_bdpt(std::string());
  sky.file = std::string(TRITRACE_SOURCE_DIR) + "/scenes/sky.json";
  RenderJob job(sky, load_job_scene(sky));
  job.prepare();
  EXPECT_EQ(job.render().image.width(), 24);
}

// Light tracing's splats land on any pixel: --tile parts and filters other than the box are
// usage errors with bdpt rather than images estimated wrong.
TEST(BdptJob, RefusesTilePartsAndOtherFiltersAsUsageErrors) {
  const struct {
    const char* flag;
    void (*set)(JobSettings&);
  } cases[] = {
      {"--tile", [](JobSettings& s) { s.tile = "0/2"; }},
      {"--filter", [](JobSettings& s) { s.filter = "gaussian"; }},
  };
  for (const auto& c : cases) {
    JobSettings s = small_bdpt("cornell");
    c.set(s);
    const Error e = error_of([&] { RenderJob(s, load_job_scene(s)); });
    EXPECT_EQ(e.subject(), c.flag);
    EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
  }
}

// --noise-threshold with bdpt through the job: --time-limit's passes (a limit that never ends)
// give the threshold's one render bit for bit, image and spp AOV, and the record says how many
// samples a pixel took on average; --spp-range stays a usage error, as for path.
TEST(BdptJob, NoiseThresholdWithTimeLimitPassesIsTheOneRender) {
  const auto run = [](JobSettings s) {
    s.aovs = "spp";
    RenderJob job(s, load_job_scene(s));
    job.prepare();
    return job.render();
  };
  JobSettings s = small_bdpt("cornell-area", "128");
  s.noise_threshold = "0.3";
  const RenderedImage alone = run(s);
  EXPECT_EQ(alone.record.noise_threshold, 0.3f);
  double taken = 0.0;
  float least = 1e9f;
  for (const glm::vec3& p : alone.aovs.spp.pixels()) {
    taken += p.x;
    least = std::min(least, p.x);
  }
  EXPECT_EQ(least, 64.0f);
  EXPECT_EQ(alone.record.mean_spp, taken / static_cast<double>(alone.aovs.spp.pixels().size()));
  s.time_limit = "1e6";
  const RenderedImage passes = run(s);
  EXPECT_TRUE(same_pixels(passes.image, alone.image));
  EXPECT_TRUE(same_pixels(passes.aovs.spp, alone.aovs.spp));
  s.time_limit.clear();
  s.spp_range = "0:64";
  const Error e = error_of([&] { RenderJob(s, load_job_scene(s)); });
  EXPECT_EQ(e.subject(), "--noise-threshold");
  EXPECT_EQ(e.exit_code(), ExitCode::kUsage);
}

// --denoise and --time-limit take bdpt as they take path (README, the render help): the denoised
// image is the denoiser on the film's own image and features (what `tritrace denoise` reads from
// the EXR of a render with those AOVs), and a time limit long enough for every pass gives the one
// render of --spp, bit for bit, with the denoiser's time recorded.
TEST(BdptJob, DenoiseIsTheDenoiserOnTheFilmAndTimeLimitPassesAreTheOneRender) {
  const auto run = [](const JobSettings& s) {
    RenderJob job(s, load_job_scene(s));
    job.prepare();
    return job.render();
  };
  JobSettings plain = small_bdpt("cornell-area", "16");
  plain.aovs = "albedo,normal,depth,variance";
  const RenderedImage noisy = run(plain);
  JobSettings s = small_bdpt("cornell-area", "16");
  s.denoise = true;
  const RenderedImage denoised = run(s);
  EXPECT_TRUE(same_pixels(denoised.image,
                          denoise_film_image(noisy.image, noisy.aovs, SamplerKind::kSobol)));
  EXPECT_FALSE(same_pixels(denoised.image, noisy.image));
  EXPECT_GT(denoised.record.denoise_seconds, 0.0);

  s.time_limit = "1e6";
  const RenderedImage passes = run(s);
  EXPECT_TRUE(same_pixels(passes.image, denoised.image));
  EXPECT_EQ(passes.record.spp, 16u);
  EXPECT_EQ(passes.record.stop, RenderStop::kSpp);
  EXPECT_GT(passes.record.denoise_seconds, 0.0);
  EXPECT_EQ(passes.record.time_limit, 1e6);
}

// --spp-range parts of a bdpt render (light tracing's splats included), written as partial films
// and merged in any order, are the one-process image bit for bit: the light image is an integer
// sum, carried by the partial film.
// With the caustic strategy too (scenes/caustics.json: each part builds the same guide from the
// same pre-pass, and the guided directions are numbers of the sample's own).
class BdptJobScenes : public ::testing::TestWithParam<const char*> {};

TEST_P(BdptJobScenes, SampleRangePartsMergeIntoTheOneProcessImage) {
  JobSettings whole_settings = small_bdpt("cornell", "21");
  if (std::string(GetParam()) != "cornell") {
    whole_settings.scene.clear();
    whole_settings.file = std::string(TRITRACE_SOURCE_DIR) + "/scenes/" + GetParam();
  }
  RenderJob whole(whole_settings, load_job_scene(whole_settings));
  whole.prepare();
  const Image want = whole.render().image;

  const std::string name = std::string(GetParam()) == "cornell" ? "cornell" : "caustics";
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("bdpt_parts_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::create_directories(dir);
  std::vector<std::string> files;
  for (const char* range : {"16:21", "0:8", "8:16"}) {
    JobSettings s = whole_settings;
    s.spp_range = range;
    RenderJob part(s, load_job_scene(s));
    part.prepare();
    Film film = part.make_film();
    part.render_to_film(film);
    ASSERT_TRUE(film.has_splats());
    files.push_back((dir / (std::string("part") + range[0] + ".exr")).string());
    part.write_part(film, files.back());
  }
  const Film merged = merge_parts(files);
  EXPECT_TRUE(merged.has_splats());
  EXPECT_TRUE(same_pixels(merged.resolve(), want));
  // A part read back keeps its light image to the bit.
  const PartialFilm back = read_partial_film(files[1]);
  JobSettings s = whole_settings;
  s.spp_range = "0:8";
  RenderJob part(s, load_job_scene(s));
  part.prepare();
  Film film = part.make_film();
  part.render_to_film(film);
  EXPECT_EQ(back.film.splats().data(), film.splats().data());
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Scenes, BdptJobScenes, ::testing::Values("cornell", "caustics.json"),
                         [](const auto& info) {
                           return std::string(info.param) == "cornell" ? "Cornell" : "Caustics";
                         });

TEST(BdptJob, SceneFilesAskForItByName) {
  const std::string text = R"({"meshes": [{"generator": "cornell-area"}],
      "integrator": {"type": "bdpt", "spp": 2, "max_depth": 3}})";
  const LoadedScene loaded =
      parse_scene_json(text, std::string(TRITRACE_SOURCE_DIR) + "/scenes/bdpt.json");
  EXPECT_EQ(loaded.integrator.kind, IntegratorSpec::Kind::kBdpt);
  EXPECT_EQ(loaded.integrator.max_depth, 3);
  EXPECT_EQ(setting_check("--integrator")("bdpt"), "");
  EXPECT_NE(setting_check("--integrator")("bidir").find("bdpt"), std::string::npos);
}

// Spot and directional lights and a lens go through the job as they go through the renderer;
// an orthographic camera turns light tracing off, so the light-tracing refusals do not apply to
// it, unless it has a lens.
TEST(BdptJob, TakesSpotAndSunLensAndOrthographicCameras) {
  JobSettings sun = small_bdpt(std::string());
  sun.file = std::string(TRITRACE_SOURCE_DIR) + "/scenes/spot_and_sun.json";
  sun.aperture = "0.05";
  RenderJob job(sun, load_job_scene(sun));
  job.prepare();
  const RenderedImage rendered = job.render();
  EXPECT_GT(rendered.image.at(12, 8).y, 0.0f);

  JobSettings tiled = small_bdpt("cornell-area");
  tiled.tile = "0/2";
  LoadedScene ortho = load_job_scene(tiled);
  ortho.scene.camera = ortho.scene.camera.orthographic(2.2f / 16.0f);
  RenderJob job2(tiled, ortho.scene, ortho.integrator);
  job2.prepare();
  EXPECT_FALSE(job2.integrator().splats());
  Film film = job2.make_film();
  EXPECT_NO_THROW(job2.render_to_film(film));

  JobSettings plain = small_bdpt("cornell-area");
  LoadedScene lensed = load_job_scene(plain);
  lensed.scene.camera = lensed.scene.camera.orthographic(0.1f).with_lens(0.05f, 3.0f);
  EXPECT_NO_THROW(RenderJob(plain, lensed.scene, lensed.integrator));
  plain.tile = "0/2";
  EXPECT_EQ(error_of([&] { RenderJob(plain, lensed.scene, lensed.integrator); }).subject(),
            "--tile");
}

// --light-paths (BdptSettings::light_paths) through the job: the flag's rule, its refusal with
// the other integrators, the scene file's key, the job's image against BdptIntegrator with the
// setting, and an identity that keeps parts of different shares apart.
TEST(BdptJob, LightPathsFlagSceneKeyAndIdentity) {
  const auto check = setting_check("--light-paths");
  ASSERT_NE(check, nullptr);
  EXPECT_EQ(check("0.25"), "");
  EXPECT_EQ(check("1"), "");
  for (const char* bad : {"0", "-0.5", "1.5", "1e-9", "nan", "abc", ""}) {
    EXPECT_NE(check(bad).find("at most 1"), std::string::npos) << bad;
  }
  JobSettings s = small_bdpt("cornell-area");
  s.light_paths = "0.25";
  RenderJob job(s, load_job_scene(s));
  EXPECT_EQ(job.spec().light_paths, 0.25f);
  job.prepare();
  const LoadedScene loaded = load_job_scene(s);
  const auto accel = make_accel(AccelKind::kBvh, loaded.scene, Kernel::kWatertight);
  const BdptIntegrator integrator(loaded.scene, {.light_paths = 0.25f});
  EXPECT_TRUE(same_pixels(job.render().image,
                          render(loaded.scene, *accel, integrator, {.threads = 1, .spp = 4})));
  // The default is `auto`: its parts merge with explicit auto's, never with an explicit share's.
  JobSettings every = small_bdpt("cornell-area");
  const RenderJob by_default(every, load_job_scene(every));
  EXPECT_TRUE(by_default.spec().light_paths_auto);
  EXPECT_FALSE(job.identity() == by_default.identity());
  every.light_paths = "auto";
  EXPECT_TRUE(RenderJob(every, load_job_scene(every)).identity() == by_default.identity());
  every.light_paths = "1";
  EXPECT_FALSE(RenderJob(every, load_job_scene(every)).identity() == by_default.identity());
  for (const char* other : {"path", "lab"}) {
    JobSettings o = s;
    o.integrator = other;
    const Error e = error_of([&] { RenderJob(o, load_job_scene(o)); });
    EXPECT_EQ(e.subject(), "--light-paths") << other;
    EXPECT_EQ(e.exit_code(), ExitCode::kUsage) << other;
  }
  const std::string path = std::string(TRITRACE_SOURCE_DIR) + "/scenes/bdpt.json";
  const LoadedScene file = parse_scene_json(R"({"meshes": [{"generator": "cornell-area"}],
      "integrator": {"type": "bdpt", "light_paths": 0.5}})",
                                            path);
  EXPECT_EQ(file.integrator.light_paths, 0.5f);
  EXPECT_FALSE(file.integrator.light_paths_auto);
  EXPECT_TRUE(parse_scene_json(R"({"meshes": [{"generator": "cornell-area"}],
      "integrator": {"type": "bdpt"}})",
                               path)
                  .integrator.light_paths_auto);
  for (const char* bad : {"0", "1.5", "\"half\""}) {
    const std::string text = std::string(R"({"meshes": [{"generator": "cornell-area"}],
        "integrator": {"type": "bdpt", "light_paths": )") +
                             bad + "}}";
    const Error e = error_of([&] { parse_scene_json(text, path); });
    EXPECT_NE(e.reason().find("/integrator/light_paths"), std::string::npos) << bad;
  }
}

// --light-paths auto through the job: the pilot chooses before the render, the image is the
// explicit share's bit for bit, the same for any thread count and the merge of --spp-range parts
// (every part runs the same pilot), the record and the identity say auto, and bad values stay
// one-line errors naming the flag or the scene file's key.
TEST(BdptJob, LightPathsAutoIsTheChosenSharesImageForAnyThreadsAndParts) {
  JobSettings s = small_bdpt("cornell-area", "21");
  s.light_paths = "auto";
  s.threads = std::string(1, '1');
  RenderJob job(s, load_job_scene(s));
  EXPECT_TRUE(job.spec().light_paths_auto);
  job.prepare();
  ASSERT_TRUE(job.light_paths_pilot().has_value());
  const float chosen = job.light_paths();
  EXPECT_LT(chosen, 1.0f);  // a diffuse box (bdpt_pilot_test)
  const RenderedImage auto_image = job.render();
  EXPECT_EQ(auto_image.record.light_paths, chosen);
  EXPECT_TRUE(auto_image.record.light_paths_auto);
  EXPECT_NE(job.light_paths_summary().find("auto chose"), std::string::npos);

  JobSettings explicit_share = s;
  explicit_share.light_paths = std::to_string(chosen);
  RenderJob fixed(explicit_share, load_job_scene(explicit_share));
  fixed.prepare();
  const RenderedImage fixed_image = fixed.render();
  EXPECT_TRUE(same_pixels(auto_image.image, fixed_image.image));
  EXPECT_FALSE(fixed_image.record.light_paths_auto);

  JobSettings threads = s;
  threads.threads = std::string(1, '3');
  RenderJob other(threads, load_job_scene(threads));
  other.prepare();
  EXPECT_TRUE(same_pixels(other.render().image, auto_image.image));

  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("bdpt_auto_parts_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::vector<std::string> files;
  for (const char* range : {"8:21", "0:8"}) {
    JobSettings p = s;
    p.spp_range = range;
    RenderJob part(p, load_job_scene(p));
    part.prepare();
    EXPECT_EQ(part.light_paths(), chosen);
    EXPECT_TRUE(part.identity() == job.identity());
    Film film = part.make_film();
    part.render_to_film(film);
    files.push_back((dir / (std::string("part") + range[0] + ".exr")).string());
    part.write_part(film, files.back());
  }
  EXPECT_TRUE(same_pixels(merge_parts(files).resolve(), auto_image.image));
  std::filesystem::remove_all(dir);

  // auto and the share it chose are different settings: their parts never merge.
  EXPECT_FALSE(job.identity() == fixed.identity());
  EXPECT_NE(job.identity().settings.find("light_paths=auto"), std::string::npos);
  const std::vector<ExrAttribute> attributes = render_attributes(auto_image.record);
  const auto has = [&](const char* name) {
    return std::any_of(attributes.begin(), attributes.end(),
                       [&](const ExrAttribute& a) { return a.name == name; });
  };
  EXPECT_TRUE(has("tritrace.lightPaths"));
  EXPECT_TRUE(has("tritrace.lightPathsChosenBy"));

  const auto check = setting_check("--light-paths");
  EXPECT_EQ(check("auto"), "");
  for (const char* bad : {"Auto", "automatic", "auto "}) {
    EXPECT_NE(check(bad).find("must be auto or the share"), std::string::npos) << bad;
  }
  const std::string path = std::string(TRITRACE_SOURCE_DIR) + "/scenes/bdpt.json";
  const LoadedScene file = parse_scene_json(R"({"meshes": [{"generator": "cornell-area"}],
      "integrator": {"type": "bdpt", "light_paths": "auto"}})",
                                            path);
  EXPECT_TRUE(file.integrator.light_paths_auto);
  const Error e = error_of([&] {
    parse_scene_json(R"({"meshes": [{"generator": "cornell-area"}],
        "integrator": {"type": "bdpt", "light_paths": "half"}})",
                     path);
  });
  EXPECT_NE(e.reason().find("\"auto\""), std::string::npos);
}

}  // namespace
}  // namespace tritrace
