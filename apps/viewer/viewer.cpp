// The SDL2 side of the viewer: the display check, the window, the event loop that sleeps in
// SDL_WaitEvent while nothing changes (and, for the path tracer, once the film has its samples),
// the per-frame render -> texture -> present, screenshots and the title and stdout reports.
// Everything that can be computed without SDL lives in the other files of this folder.
#include "viewer.h"

#include <SDL.h>
#include <X11/Xlib.h>
#include <X11/Xproto.h>

#include <atomic>
#include <chrono>
#include <clocale>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "film_parts.h"
#include "flags/flag_values.h"
#include "frame_report.h"
#include "overlay.h"
#include "pixels.h"
#include "refinement.h"
#include "sample_schedule.h"
#include "screenshot.h"
#include "tritrace/accel/make_accel.h"
#include "tritrace/denoise/denoiser.h"
#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/job/render_job.h"
#include "tritrace/render/film.h"
#include "tritrace/render/make_integrator.h"
#include "tritrace/render/renderer.h"
#include "tritrace/scene/io/load_progress.h"
#include "tritrace/scene/io/scene_loader.h"
#include "view_state.h"

#ifndef TRITRACE_OVERLAY_FONT
#define TRITRACE_OVERLAY_FONT "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf"
#endif

namespace tritrace::view {
namespace {

using Clock = std::chrono::steady_clock;

// The render time a resting frame of the path tracer aims at: samples arrive several times a
// second, and a key pressed meanwhile waits no longer than this for the frame to end.
constexpr double kFrameBudgetMs = 60.0;
// The window's size while the scene loads, when no --width/--height is given.
constexpr int kLoadingWidth = 640, kLoadingHeight = 480;

double seconds_since(Clock::time_point start, Clock::time_point end) {
  return std::chrono::duration<double>(end - start).count();
}
double ms_since(Clock::time_point start) {
  return 1e3 * seconds_since(start, Clock::now());
}

Error no_display() {
  return Error("", kNoDisplay);
}

bool env_set(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && value[0] != '\0';
}

// SDL wakes its own event wait by sending a message to the window over a second X connection, also
// when the event that ends the wait is the one that quits (Esc, closing the window). The window is
// then destroyed at once, and if the server handles that message after the destruction it answers
// BadWindow, which Xlib's default handler turns into exit(1) during SDL_Quit. That one error is
// harmless and ignored; every other goes to the handler that was installed before (Xlib's).
// A C callback cannot carry state, hence the one global, set once before any thread starts.
XErrorHandler g_previous_x_error_handler = nullptr;

int ignore_wakeup_after_close(Display* display, XErrorEvent* error) {
  if (error->error_code == BadWindow && error->request_code == X_SendEvent) return 0;
  return g_previous_x_error_handler != nullptr ? g_previous_x_error_handler(display, error) : 0;
}

constexpr int kDisplayAttempts = 10;

// Owns SDL's video subsystem for the viewer's lifetime. SDL may only use a real windowing system:
// without one it could pick a driver that shows nothing (offscreen, KMS on a console), and the
// user would wait for a window that never appears.
class SdlVideo {
 public:
  SdlVideo() {
    if (!env_set("DISPLAY") && !env_set("WAYLAND_DISPLAY")) throw no_display();
    // Only the system the environment names: SDL would otherwise try the others in turn when it
    // fails (Wayland's library then prints its own complaint on stderr). A user's own
    // SDL_VIDEODRIVER still wins (a hint at default priority yields to the environment).
    SDL_SetHint(SDL_HINT_VIDEODRIVER, env_set("DISPLAY") ? "x11" : "wayland");
    // When SDL_RENDER_DRIVER=software picks SDL's software renderer, let it draw into the window's
    // own framebuffer (X shared memory) instead of probing OpenGL to present it, which loads the
    // GL driver for nothing (and, with Mesa, leaves allocations LeakSanitizer reports).
    SDL_SetHint(SDL_HINT_FRAMEBUFFER_ACCELERATION, "0");
    // The frame is made on the CPU; all the window needs is a copy of it. SDL's software renderer
    // does that with one shared-memory copy, which is faster in every part of a frame than its
    // OpenGL renderer where OpenGL is Mesa's CPU rasteriser, as under Xvfb (docs/PERFORMANCE.md,
    // "Viewer: frame time and display overhead").
    // SDL_RENDER_DRIVER=opengl (the environment wins over this default) picks OpenGL.
    SDL_SetHint(SDL_HINT_RENDER_DRIVER, "software");
    // SDL hands the window title (UTF-8) to Xlib, which converts text by LC_CTYPE; in the "C"
    // locale every program starts in, a title with anything beyond ASCII (the title's dash) fails
    // that conversion and the window keeps its first title. Text conversion is all LC_CTYPE
    // decides here (numbers are LC_NUMERIC's, untouched); UTF-8 is the encoding SDL gives.
    if (std::setlocale(LC_CTYPE, "C.UTF-8") == nullptr) std::setlocale(LC_CTYPE, "");
    // Before SDL_Init: SDL keeps the handler it finds and puts it back before it closes its X
    // connections, which is when the error arrives.
    if (env_set("DISPLAY")) {
      g_previous_x_error_handler = XSetErrorHandler(ignore_wakeup_after_close);
    }
    // A display that is there can still refuse one connection: with Xvfb on a loaded machine,
    // SDL's first XOpenDisplay can fail while the server goes on serving other clients, and a
    // second try 100 ms later connects. So a few tries, about a second in all, before calling the
    // display missing.
    for (int attempt = 1; SDL_Init(SDL_INIT_VIDEO) != 0; ++attempt) {
      if (attempt == kDisplayAttempts) throw no_display();
      SDL_Delay(100);
    }
    const char* driver = SDL_GetCurrentVideoDriver();
    const std::string_view name = driver != nullptr ? driver : "";
    if (name != "x11" && name != "wayland") {
      SDL_Quit();
      throw no_display();
    }
  }
  ~SdlVideo() {
    SDL_Quit();
    if (env_set("DISPLAY")) XSetErrorHandler(g_previous_x_error_handler);
  }
  SdlVideo(const SdlVideo&) = delete;
  SdlVideo& operator=(const SdlVideo&) = delete;
};

struct WindowDeleter {
  void operator()(SDL_Window* w) const { SDL_DestroyWindow(w); }
};
struct RendererDeleter {
  void operator()(SDL_Renderer* r) const { SDL_DestroyRenderer(r); }
};
struct TextureDeleter {
  void operator()(SDL_Texture* t) const { SDL_DestroyTexture(t); }
};

// Per-frame costs in milliseconds: events (handling input and setting the view), render (the
// Renderer), denoise (the denoiser, on frames that run it), convert (float image to texture
// pixels), upload (locking the texture and handing the pixels to SDL), present (copy to the window
// and flip).
struct FrameTimes {
  double events = 0, render = 0, denoise = 0, convert = 0, upload = 0, present = 0;
  double total() const { return events + render + denoise + convert + upload + present; }
};

HeldKeys held_keys() {
  const Uint8* k = SDL_GetKeyboardState(nullptr);
  // Scancodes, i.e. key positions: W/A/S/D and Q/E keep their shape on any keyboard layout.
  HeldKeys h;
  h.left = k[SDL_SCANCODE_LEFT] != 0;
  h.right = k[SDL_SCANCODE_RIGHT] != 0;
  h.up = k[SDL_SCANCODE_UP] != 0;
  h.down = k[SDL_SCANCODE_DOWN] != 0;
  h.w = k[SDL_SCANCODE_W] != 0;
  h.s = k[SDL_SCANCODE_S] != 0;
  h.a = k[SDL_SCANCODE_A] != 0;
  h.d = k[SDL_SCANCODE_D] != 0;
  h.q = k[SDL_SCANCODE_Q] != 0;
  h.e = k[SDL_SCANCODE_E] != 0;
  return h;
}

void print_line(const std::string& line) {
  std::printf("%s\n", line.c_str());
  std::fflush(stdout);  // stdout is often a pipe or a file: each line should arrive at once
}

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& options) : options_(options) {}

  int run() {
    // The display first: without one, fail at once rather than after loading a large scene.
    video_.emplace();
    const SceneOverrides overrides = scene_overrides(options_.scene);
    // The window opens at once, at the size the flags ask for (the scene's own size once it is
    // loaded), and shows what is being loaded and built: a ten-million-triangle model takes
    // seconds, which a blank window that does not answer would hide.
    window_.reset(SDL_CreateWindow("tritrace", SDL_WINDOWPOS_UNDEFINED, SDL_WINDOWPOS_UNDEFINED,
                                   overrides.width.value_or(kLoadingWidth),
                                   overrides.height.value_or(kLoadingHeight),
                                   SDL_WINDOW_RESIZABLE));
    if (!window_) throw no_display();
    renderer_.reset(SDL_CreateRenderer(window_.get(), -1, 0));
    if (!renderer_) throw Error("SDL", std::string("cannot create a renderer: ") + SDL_GetError());
    overlay_.emplace(TRITRACE_OVERLAY_FONT);

    if (!load_showing_progress()) return 0;  // closed while loading
    width_ = loaded_.scene.camera.width();
    height_ = loaded_.scene.camera.height();
    int shown_width = 0, shown_height = 0;
    SDL_GetWindowSize(window_.get(), &shown_width, &shown_height);
    if (shown_width != width_ || shown_height != height_) {
      SDL_SetWindowSize(window_.get(), width_, height_);
    }
    start_ = initial_view(options_.scene, loaded_);
    view_ = start_;
    rates_ = MotionRates::for_distance(start_.distance);
    // The job's integrator, options and accel are those `tritrace render` makes from the same
    // flags.
    spec_ = job_->spec();
    path_ = job_->path();
    render_options_ = job_->options();
    check_path_only();
    limits_.max_spp = spec_.spp;
    limits_.noise_threshold = render_options_.noise_threshold;
    JobSettings time_limit;  // the library's conversion of the checked text
    time_limit.time_limit = options_.time_limit;
    limits_.time_limit_seconds = time_limit_seconds(time_limit);
    // As `tritrace render --time-limit`: without --spp, refinement goes on until the time is up.
    if (limits_.time_limit_seconds && options_.scene.spp.empty()) {
      limits_.max_spp = spec_.spp = kMaxSpp;
    }
    // Frames accumulate uniformly; the adaptive levels set the threshold themselves.
    render_options_.noise_threshold = 0.0f;
    schedule_.emplace(uniform_end(limits_), kFrameBudgetMs);
    denoise_ = path_ && options_.denoise;
    return loop();
  }

 private:
  // The viewer's own path-tracer settings, refused with the lab integrator for the reasons the
  // render job refuses them (it checks --noise-threshold itself).
  void check_path_only() const {
    if (path_) return;
    if (options_.time_limit.empty() && !options_.denoise) return;
    const bool time = !options_.time_limit.empty();
    throw Error(time ? "--time-limit" : "--denoise",
                std::string("applies to the path tracer; ") +
                    (time ? "the lab integrator takes one sample per pixel"
                          : "the lab integrator's image has no noise"),
                ExitCode::kUsage);
  }

  // Loads the scene and builds its accel on a thread of their own, while this one keeps the
  // window answering and shows the phase (the words of `tritrace render`'s phase line) with its
  // time in the title and in the window. Returns false when the window was closed (or Esc
  // pressed) meanwhile: the load cannot be interrupted, so the caller leaves without waiting for
  // it (see leave_while_loading). Rethrows what the load threw.
  bool load_showing_progress() {
    std::mutex mutex;
    std::string phase = loading_phase(options_.scene);
    Clock::time_point phase_start = Clock::now();
    std::exception_ptr error;
    std::atomic<bool> done{false};
    std::atomic<bool> building{false};
    LoadProgress load_progress;
    const Uint32 wake = SDL_RegisterEvents(1);
    std::thread worker([&] {
      try {
        {
          const LoadProgressScope report(&load_progress);
          loaded_ = load_job_scene(options_.scene);
        }
        building = true;
        {
          const std::lock_guard<std::mutex> lock(mutex);
          phase = building_phase(accel_kind(options_.scene), loaded_.scene.drawn_triangles());
          phase_start = Clock::now();
        }
        // The viewer traces frame after frame: auto means the tree that traces fastest.
        job_ = std::make_unique<RenderJob>(options_.scene, loaded_.scene, loaded_.integrator);
        job_->prepare(nullptr, nullptr, std::numeric_limits<double>::infinity());
      } catch (...) {
        error = std::current_exception();
      }
      done = true;
      if (wake != static_cast<Uint32>(-1)) {
        SDL_Event e{};
        e.type = wake;
        SDL_PushEvent(&e);  // thread-safe: ends the wait below at once
      }
    });
    while (!done) {
      std::string line;
      {
        const std::lock_guard<std::mutex> lock(mutex);
        char seconds[32];
        std::snprintf(seconds, sizeof seconds, "  %.1f s",
                      seconds_since(phase_start, Clock::now()));
        // The loading step and how far it is, as `tritrace render`'s phase line shows it.
        const std::string step = building ? std::string() : load_progress.describe();
        line = phase + (step.empty() ? "" : "  " + step) + seconds;
      }
      SDL_SetWindowTitle(window_.get(), ("tritrace \u2014 " + line).c_str());
      SDL_Renderer* r = renderer_.get();
      SDL_SetRenderDrawColor(r, 0, 0, 0, 255);
      SDL_RenderClear(r);
      overlay_->draw(r, {"tritrace-view", line});
      SDL_RenderPresent(r);
      SDL_Event e;
      if (SDL_WaitEventTimeout(&e, 100) != 0) {
        do {
          const bool closed =
              e.type == SDL_QUIT ||
              (e.type == SDL_WINDOWEVENT && e.window.event == SDL_WINDOWEVENT_CLOSE) ||
              (e.type == SDL_KEYDOWN && e.key.keysym.sym == SDLK_ESCAPE);
          if (closed) leave_while_loading(worker);
        } while (SDL_PollEvent(&e) != 0);
      }
    }
    worker.join();
    if (error) std::rethrow_exception(error);
    return true;
  }

  // The window was closed while the scene loads: the loading thread cannot be stopped, and
  // waiting for it would keep a closed window's process running for the rest of the load, so the
  // process ends here, as its exit status 0 says the user asked. Nothing is lost: the viewer
  // writes no file but the screenshots, and none can have been taken yet.
  [[noreturn]] static void leave_while_loading(std::thread& worker) {
    worker.detach();
    std::fflush(stdout);
    std::_Exit(0);
  }

  int loop() {
    bool need_render = true, need_present = false, screenshot = false;
    Clock::time_point last_motion = Clock::now();
    std::vector<SDL_Event> events;
    for (;;) {
      // The keys held since the last events: they moved the view until now.
      const Motion motion = benchmarking() ? Motion{1, 0, {}} : motion_from(held_keys());
      wait_for_events(need_render || need_present || screenshot || motion.any(), events);
      const Clock::time_point woke = Clock::now();
      if (motion.any()) {
        view_ = advance(view_, motion, seconds_since(last_motion, woke), rates_);
        need_render = true;
      }
      last_motion = woke;

      for (const SDL_Event& e : events) {
        if (e.type == SDL_QUIT) return 0;
        if (e.type == SDL_WINDOWEVENT) {
          if (e.window.event == SDL_WINDOWEVENT_CLOSE) return 0;
          if (e.window.event == SDL_WINDOWEVENT_SIZE_CHANGED) {
            width_ = std::clamp(e.window.data1, 1, kMaxImageSide);
            height_ = std::clamp(e.window.data2, 1, kMaxImageSide);
            need_render = true;
          } else if (e.window.event == SDL_WINDOWEVENT_EXPOSED) {
            need_present = true;
          }
        }
        if (e.type != SDL_KEYDOWN || e.key.repeat != 0) continue;
        switch (e.key.keysym.sym) {
          case SDLK_ESCAPE:
            return 0;
          case SDLK_r:
            view_ = start_;
            need_render = true;
            break;
          case SDLK_p:
            screenshot = true;
            break;
          case SDLK_h:
            show_overlay_ = !show_overlay_;
            need_present = true;
            break;
          case SDLK_n:
            // The path tracer's film gains (or may drop) its AOVs when it next starts over, at
            // once when they are missing.
            if (path_) {
              denoise_ = !denoise_;
              denoised_spp_ = 0;
              need_render = true;
            }
            break;
          default:
            break;
        }
      }

      FrameTimes times;
      times.events = ms_since(woke);
      bool new_image = false;
      if (need_render) {
        new_image = render_frame(times);
        if (new_image) need_present = true;
        // The path tracer goes on refining while the view rests, until a limit stops it.
        need_render = path_ && stopped_ == StopReason::kNone;
      }
      if (need_present) {
        present(times);
        need_present = false;
      }
      if (new_image) frame_done(times);
      if (screenshot) {
        save_screenshot();
        screenshot = false;
      }
      if (options_.print_state && !motion_from(held_keys()).any() && printed_view_ != image_view_) {
        print_line("view: " + command_for_view());
        printed_view_ = image_view_;
      }
      if (!options_.quiet && report_.pending() &&
          report_.seconds_until_due(seconds_since(epoch_, Clock::now())) == 0.0) {
        print_line(report_.take_line(seconds_since(epoch_, Clock::now())));
      }
      if (benchmarking() && static_cast<int>(benchmark_.size()) >= options_.benchmark_frames) {
        print_benchmark();
        return 0;
      }
    }
  }

  bool benchmarking() const { return options_.benchmark_frames > 0; }

  // Returns at once with whatever is queued when `busy`; otherwise sleeps in SDL until an event
  // arrives, or until a pending "Render time" line is due.
  void wait_for_events(bool busy, std::vector<SDL_Event>& events) {
    events.clear();
    SDL_Event e;
    if (!busy) {
      int timeout_ms = -1;
      if (!options_.quiet && report_.pending()) {
        const double wait = report_.seconds_until_due(seconds_since(epoch_, Clock::now()));
        timeout_ms = static_cast<int>(std::ceil(wait * 1e3));
      }
      const int got = timeout_ms < 0 ? SDL_WaitEvent(&e) : SDL_WaitEventTimeout(&e, timeout_ms);
      if (got != 0) events.push_back(e);
    }
    while (SDL_PollEvent(&e) != 0) events.push_back(e);
  }

  // Renders the next frame into image_ and the texture; false when there was nothing to add (the
  // path tracer's film already holds its samples for this view).
  bool render_frame(FrameTimes& times) {
    const Clock::time_point start = Clock::now();
    try {
      apply_overrides(loaded_, view_overrides(view_, width_, height_));
    } catch (const Error& e) {
      // A view the scene cannot take (a degenerate camera): keep the last good one.
      std::fprintf(stderr, "tritrace-view: %s\n", e.what());
      view_ = image_view_;
      apply_overrides(loaded_, view_overrides(view_, width_, height_));
    }
    const Scene& scene = loaded_.scene;
    // The path tracer builds its light sampler from the scene's lights when it is made, so it is
    // made again when the light moves: always the integrator `tritrace render` makes for the scene
    // with that light.
    if (integrator_light_ != view_.light) {
      job_->remake_integrator();
      integrator_light_ = view_.light;
    }
    times.events += ms_since(start);

    RenderStats stats;
    if (path_) {
      // Any change of the view or size starts the film over; otherwise this frame adds the
      // next whole sample indices [taken, taken + k) of every pixel, so the film after N samples
      // holds exactly the sums `tritrace render --spp N` makes, added in the same order. With a
      // noise threshold, past uniform_end the frame renders a tile part of the next adaptive
      // level instead (refinement.h).
      const int w = scene.camera.width(), h = scene.camera.height();
      const bool restart = film_.width() != w || film_.height() != h || film_view_ != view_ ||
                           (denoise_ && !has_denoise_aovs(film_.aovs()));
      const StopReason stopped_before = stopped_;
      bool added = false;
      if (restart) {
        film_ = Film(w, h, denoise_ ? kDenoiseAovs : AovSet{});
        film_view_ = view_;
        denoised_spp_ = 0;
        level_.reset();
        level_ms_per_sample_ = 0.0;
        converged_ = false;
        stopped_ = StopReason::kNone;
        rest_start_ = start;
      }
      if (stopped_ == StopReason::kNone) {
        const uint32_t spp = schedule_->next_frame(restart);
        if (spp > 0) {
          RenderOptions options = render_options_;
          options.first_sample = schedule_->samples_taken();
          options.spp = spp;
          job_->render_to_film(film_, options, &stats);
          schedule_->frame_rendered(spp, stats.milliseconds);
          image_spp_ = schedule_->samples_taken();
          added = true;
        } else {
          added = render_level_part(w, h, stats);
        }
        stopped_ =
            stop_reason(limits_, image_spp_, converged_, seconds_since(rest_start_, Clock::now()));
        // A level left unfinished is dropped: the image stays the last whole one.
        if (stopped_ != StopReason::kNone) level_.reset();
      }
      if (!added && stopped_ == stopped_before) {
        if (level_) show_level_progress(stats.milliseconds);
        // A denoised image may still be due (the key was pressed), or the image shown is
        // denoised but should no longer be (the key turned it off).
        if (!denoise_due() && !(shown_denoised_ && !keep_denoised())) return false;
      }
    } else {
      image_ = job_->render(&stats).image;
    }
    image_view_ = view_;
    times.render = stats.milliseconds;
    if (stats.milliseconds > 0.0) {  // not a frame that only denoised the film
      threads_ = stats.threads;
      mrays_ = stats.mrays_per_second();
    }

    const Clock::time_point upload = Clock::now();
    if (path_) {
      const Clock::time_point resolve = Clock::now();
      if (denoise_due()) {
        image_ = denoised_frame();
        denoised_spp_ = image_spp_;
        shown_denoised_ = true;
        times.denoise = ms_since(resolve);
      } else if (!keep_denoised()) {
        image_ = film_.resolve();
        shown_denoised_ = false;
        times.convert = ms_since(resolve);
      }
      // Otherwise the last denoised image of this view stays until the next is due.
    }
    if (!texture_ || texture_width_ != image_.width() || texture_height_ != image_.height()) {
      texture_.reset(SDL_CreateTexture(renderer_.get(), SDL_PIXELFORMAT_ARGB8888,
                                       SDL_TEXTUREACCESS_STREAMING, image_.width(),
                                       image_.height()));
      if (!texture_) {
        throw Error("SDL", std::string("cannot create a texture: ") + SDL_GetError());
      }
      texture_width_ = image_.width();
      texture_height_ = image_.height();
    }
    void* pixels = nullptr;
    int pitch = 0;
    if (SDL_LockTexture(texture_.get(), nullptr, &pixels, &pitch) == 0) {
      const Clock::time_point convert = Clock::now();
      pack_argb8888(image_, static_cast<uint8_t*>(pixels), pitch, encoding());
      times.convert += ms_since(convert);
      SDL_UnlockTexture(texture_.get());
    }
    times.upload = ms_since(upload) - times.convert;
    return true;
  }

  // Renders the next tile part of the next adaptive level (starting the level when none is under
  // way); true when that completed the level, which then becomes the film shown. False, with
  // nothing rendered, when there is no level left (the image has max_spp samples).
  bool render_level_part(int w, int h, RenderStats& stats) {
    if (!level_) {
      const uint32_t spp = next_adaptive_level(image_spp_, limits_.max_spp);
      if (spp == 0) return false;
      const int tiles =
          ((w + kPartTileSize - 1) / kPartTileSize) * ((h + kPartTileSize - 1) / kPartTileSize);
      // The last level's cost per sample where there is one (pixels that stopped make an
      // adaptive sample cheaper than a uniform frame's), else the uniform frames'.
      const double ms_per_sample =
          level_ms_per_sample_ > 0.0 ? level_ms_per_sample_ : schedule_->ms_per_sample();
      level_ = Level{};
      level_->spp = spp;
      // Light tracing (bdpt) splats onto every tile, so its levels cannot be split into tile
      // parts: a level is one render (longer frames while it refines).
      level_->parts =
          job_->integrator().splats() ? 1 : level_parts(ms_per_sample, spp, kFrameBudgetMs, tiles);
    }
    Level& level = *level_;
    // The spp AOV says whether every pixel stopped before the level's end (converged).
    AovSet aovs = film_.aovs();
    aovs.spp = true;
    Film part(w, h, aovs);
    RenderOptions options = render_options_;
    options.first_sample = 0;
    options.spp = level.spp;
    options.noise_threshold = limits_.noise_threshold;
    options.tile_part = level.next_part;
    options.tile_parts = level.parts;
    job_->render_to_film(part, options, &stats);
    level.milliseconds += stats.milliseconds;
    // One part is the whole level, light image (bdpt's splats) included; copy_tile_part copies
    // the sums only.
    if (level.parts == 1) {
      level.film = std::move(part);
    } else {
      copy_tile_part(part, level.next_part, level.parts, level.film);
    }
    if (++level.next_part < level.parts) return false;
    level_ms_per_sample_ = level.milliseconds / level.spp;
    float most = 0.0f;
    const Image taken = level.film.resolve_spp();
    for (const glm::vec3& p : taken.pixels()) most = std::max(most, p.x);
    converged_ = most < static_cast<float>(level.spp);
    film_ = std::move(level.film);
    image_spp_ = level.spp;
    level_.reset();
    return true;
  }

  // The title while a level renders: the image's, and how far the level is.
  void show_level_progress(double part_ms) {
    PathTitle title = path_title();
    title.refining = "refining to " + std::to_string(level_->spp) + " spp, part " +
                     std::to_string(level_->next_part) + "/" + std::to_string(level_->parts);
    SDL_SetWindowTitle(window_.get(),
                       window_title(part_ms, image_.width(), image_.height(), title).c_str());
  }

  static bool has_denoise_aovs(const AovSet& aovs) {
    return aovs.albedo && aovs.normal && aovs.depth && aovs.variance;
  }

  // The viewer denoises only a view at rest: the film not started over by this frame (so at 2 spp
  // or more, with both halves for the variance), and then each time its samples have doubled
  // since the last denoised image (2, 4, 8, ... spp) and once more when refinement stops.
  // Denoising costs about as much as rendering 16 spp, so its share of the time falls as samples
  // grow, while the image shown improves at least as fast as the noise the samples remove.
  bool denoise_due() const {
    if (!denoise_ || image_spp_ < 2 || film_.width() == 0 || !has_denoise_aovs(film_.aovs())) {
      return false;
    }
    if (denoised_spp_ == 0) return true;
    return image_spp_ >= 2 * denoised_spp_ ||
           (stopped_ != StopReason::kNone && image_spp_ > denoised_spp_);
  }

  // The denoised image shown is of this film and still wanted.
  bool keep_denoised() const { return denoise_ && shown_denoised_ && denoised_spp_ > 0; }

  // The film denoised with its own features and the variance of its sample halves, exactly as
  // `tritrace render --denoise` denoises its film.
  Image denoised_frame() const {
    return denoise_film_image(film_.resolve(), film_.resolve_aovs(), render_options_.sampler);
  }

  // How image_ becomes bytes, in the window as in files: as `tritrace render` writes it.
  ImageEncoding encoding() const { return path_ ? ImageEncoding::srgb() : ImageEncoding::lab(); }

  // How image_ was rendered, for its reproducing command: the path tracer with the samples the
  // image holds.
  IntegratorSpec rendered_spec() const {
    IntegratorSpec rendered = spec_;
    if (path_) rendered.spp = image_spp_;
    return rendered;
  }

  void present(FrameTimes& times) {
    const Clock::time_point start = Clock::now();
    SDL_Renderer* r = renderer_.get();
    SDL_SetRenderDrawColor(r, 0, 0, 0, 255);
    SDL_RenderClear(r);
    if (texture_) {
      // Drawn at its own size from the top-left corner: pixels map 1:1 to the window's, and a
      // resize shows the old frame unscaled until the new one is rendered.
      const SDL_Rect at{0, 0, texture_width_, texture_height_};
      SDL_RenderCopy(r, texture_.get(), nullptr, &at);
    }
    if (show_overlay_) overlay_->draw(r, overlay_lines());
    SDL_RenderPresent(r);
    times.present = ms_since(start);
  }

  void frame_done(const FrameTimes& times) {
    last_times_ = times;
    const int w = image_.width(), h = image_.height();
    const std::string title =
        path_ ? window_title(times.total(), w, h, path_title()) : window_title(times.total(), w, h);
    SDL_SetWindowTitle(window_.get(), title.c_str());
    if (!options_.quiet && !benchmarking()) report_.add_frame(times.total());
    if (benchmarking()) benchmark_.push_back(times);
  }

  // What the path tracer's title says besides the frame time and size.
  PathTitle path_title() const {
    return PathTitle{.spp = image_spp_,
                     .target_spp = limits_.max_spp,
                     .noise_threshold = limits_.noise_threshold,
                     .denoise = denoise_,
                     .denoised_spp = shown_denoised_ ? denoised_spp_ : 0,
                     .stopped = std::string(stop_reason_text(stopped_)),
                     .refining = {}};
  }

  // The image shown, with --denoise when it is denoised.
  std::string command_for_image() const {
    JobSettings flags = options_.scene;
    flags.denoise = shown_denoised_;
    return render_command_line(flags, image_view_, image_.width(), image_.height(),
                               rendered_spec());
  }

  // The view at rest as the image it converges to: for the path tracer, at the scene's spp (and
  // denoised when N is on).
  std::string command_for_view() const {
    JobSettings flags = options_.scene;
    flags.denoise = denoise_;
    return render_command_line(flags, image_view_, image_.width(), image_.height(), spec_);
  }

  void save_screenshot() {
    std::error_code ec;
    const std::filesystem::path folder = std::filesystem::current_path(ec);
    const std::filesystem::path path = next_screenshot_path(ec ? "." : folder);
    try {
      write_image(image_, path.string(), encoding());
      // A denoised screenshot's command has --denoise: the viewer denoises as render does.
      print_line("saved " + path.string() + ": " + command_for_image());
    } catch (const Error& e) {
      // A full disk or a read-only folder must not end the session: say so and go on.
      std::fprintf(stderr, "tritrace-view: %s\n", e.what());
    }
  }

  std::vector<std::string> overlay_lines() const {
    char stats[256];
    std::snprintf(stats, sizeof stats,
                  "%.1f ms/frame: render %.1f, denoise %.1f, convert %.2f, upload %.2f, "
                  "present %.2f, events %.2f",
                  last_times_.total(), last_times_.render, last_times_.denoise, last_times_.convert,
                  last_times_.upload, last_times_.present, last_times_.events);
    char scene[256];
    std::snprintf(
        scene, sizeof scene, "%dx%d, %zu triangles, %s, %s, %d threads, %.3g Mrays/s",
        image_.width(), image_.height(), static_cast<size_t>(loaded_.scene.drawn_triangles()),
        std::string(accel_name(accel_kind(options_.scene))).c_str(),
        std::string(kernel_name(kernel_choice(options_.scene))).c_str(), threads_, mrays_);
    std::string view = "yaw " + format_double(image_view_.yaw) + " rad, distance " +
                       format_float(image_view_.distance);
    if (image_view_.light) view += ", light " + format_vec3(*image_view_.light);
    std::string shading = "integrator " + std::string(integrator_name(spec_.kind));
    if (path_) {
      shading += ": " + std::to_string(image_spp_) + " of " + std::to_string(limits_.max_spp) +
                 " spp" +
                 (stopped_ != StopReason::kNone
                      ? " (stopped: " + std::string(stop_reason_text(stopped_)) + ")"
                      : std::string()) +
                 ", " + std::string(sampler_name(spec_.sampler)) + " sampler, seed " +
                 std::to_string(spec_.seed) + ", max depth " + std::to_string(spec_.max_depth) +
                 ", " + std::string(filter_name(render_options_.filter)) + " filter";
    }
    std::string limits;
    if (path_) {
      limits = "refinement at rest: up to " + std::to_string(limits_.max_spp) + " spp";
      if (limits_.adaptive()) {
        limits += ", noise threshold " + format_float(limits_.noise_threshold);
      }
      if (limits_.time_limit_seconds) {
        limits += ", time limit " + format_double(*limits_.time_limit_seconds) + " s";
      }
    }
    std::vector<std::string> lines{"tritrace-view (H hides this)", stats, scene, view, shading};
    if (path_) lines.push_back(limits);
    const std::vector<std::string> keys{
        "",
        "Left/Right    orbit the camera",
        "Up/Down       move the camera forward/back",
        "W/S A/D Q/E   move the light +z/-z, -x/+x, up/down",
        "N denoise the resting image (path; on: " + std::string(denoise_ ? "yes" : "no") + ")",
        "R reset   P screenshot   H help   Esc quit"};
    lines.insert(lines.end(), keys.begin(), keys.end());
    return lines;
  }

  void print_benchmark() const {
    std::vector<double> events, render, convert, upload, present, total;
    for (const FrameTimes& t : benchmark_) {
      events.push_back(t.events);
      render.push_back(t.render);
      convert.push_back(t.convert);
      upload.push_back(t.upload);
      present.push_back(t.present);
      total.push_back(t.total());
    }
    std::printf(
        "benchmark: %zu frames at %dx%d, medians: frame %.2f ms, render %.2f ms, convert %.3f "
        "ms, upload %.3f ms, present %.3f ms, events %.3f ms (SDL renderer: %s)\n",
        benchmark_.size(), image_.width(), image_.height(), median(total), median(render),
        median(convert), median(upload), median(present), median(events), renderer_name().c_str());
    std::fflush(stdout);
  }

  std::string renderer_name() const {
    SDL_RendererInfo info;
    if (SDL_GetRendererInfo(renderer_.get(), &info) != 0 || info.name == nullptr) return "?";
    return info.name;
  }

  const ViewerOptions& options_;
  LoadedScene loaded_;
  // Over loaded_.scene, whose camera and light each frame's view sets.
  std::unique_ptr<RenderJob> job_;
  RenderOptions render_options_;
  IntegratorSpec spec_;  // what `tritrace render` would use with the same flags
  bool path_ = false;    // spec_ is the path tracer: accumulate samples while the view rests
  std::optional<glm::vec3> integrator_light_;  // the light the job's integrator was made with
  Film film_;                                  // the path tracer's samples of film_view_
  ViewState film_view_;
  std::optional<SampleSchedule> schedule_;
  uint32_t image_spp_ = 0;        // the samples per pixel image_ is the mean of (path)
  RefinementLimits limits_;       // --spp, --noise-threshold, --time-limit (path)
  Clock::time_point rest_start_;  // when the film last started over: the view came to rest
  StopReason stopped_ = StopReason::kNone;  // why the film takes no more samples
  bool converged_ = false;  // the last adaptive level stopped every pixel before its end
  // An adaptive level being rendered a tile part per frame, into a film of its own; film_ keeps
  // the last whole image until the level is complete.
  struct Level {
    uint32_t spp = 0;
    int parts = 1;
    int next_part = 0;
    double milliseconds = 0.0;  // the render time of its parts so far
    Film film;
  };
  std::optional<Level> level_;
  double level_ms_per_sample_ = 0.0;  // the last whole level's; 0: none since the restart
  // N: denoise the path tracer's film while the view rests (denoise_due). The film then keeps the
  // denoiser's features and the even half's sums for the variance.
  static constexpr AovSet kDenoiseAovs{
      .albedo = true, .normal = true, .depth = true, .variance = true};
  bool denoise_ = false;
  uint32_t denoised_spp_ = 0;    // the film's spp at the last denoised image; 0: none yet
  bool shown_denoised_ = false;  // image_ is a denoised image
  ViewState start_, view_;
  ViewState image_view_;                   // the view image_ shows
  std::optional<ViewState> printed_view_;  // the last view --print-state printed
  MotionRates rates_;
  int width_ = 0, height_ = 0;  // the window's, which the next frame renders at
  Image image_;
  int threads_ = 0;
  double mrays_ = 0.0;
  FrameTimes last_times_;
  RenderTimeReport report_;
  std::vector<FrameTimes> benchmark_;
  const Clock::time_point epoch_ = Clock::now();
  bool show_overlay_ = false;

  // Destroyed in reverse order: textures before their renderer, the renderer before the window,
  // and SDL itself last.
  std::optional<SdlVideo> video_;
  std::unique_ptr<SDL_Window, WindowDeleter> window_;
  std::unique_ptr<SDL_Renderer, RendererDeleter> renderer_;
  std::unique_ptr<SDL_Texture, TextureDeleter> texture_;
  int texture_width_ = 0, texture_height_ = 0;
  std::optional<Overlay> overlay_;
};

}  // namespace

int run_viewer(const ViewerOptions& options) {
  Viewer viewer(options);
  return viewer.run();
}

}  // namespace tritrace::view
