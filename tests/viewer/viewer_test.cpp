// Viewer integration tests, as a person uses it: a real X server (Xvfb), the real tritrace-view,
// real key presses from xdotool (XTEST, to the focused window), screenshots saved with P and
// compared pixel for pixel with `tritrace render` of the command line the viewer printed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <X11/Xlib.h>

#include "tritrace/image/image_io.h"

#if !defined(TRITRACE_VIEW_PATH) || !defined(TRITRACE_CLI_PATH)
#error "TRITRACE_VIEW_PATH and TRITRACE_CLI_PATH must name the built executables"
#endif

extern char** environ;

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {

using Clock = std::chrono::steady_clock;

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Words(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream in(text);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// The environment of this process with DISPLAY (and WAYLAND_DISPLAY) replaced: `display` empty
// means none at all. SDL_RENDER_DRIVER is dropped so that the viewer runs as a user starts it, with
// its default renderer (SDL's software one).
std::vector<std::string> Environment(const std::string& display) {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string var = *e;
    if (var.rfind("DISPLAY=", 0) == 0 || var.rfind("WAYLAND_DISPLAY=", 0) == 0 ||
        var.rfind("SDL_RENDER_DRIVER=", 0) == 0) {
      continue;
    }
    env.push_back(var);
  }
  if (!display.empty()) env.push_back("DISPLAY=" + display);
  return env;
}

// Starts `args` in `cwd` with `env`, stdin from /dev/null and stdout/stderr to files (or
// /dev/null when empty). Returns the pid, or -1.
pid_t Spawn(const std::vector<std::string>& args, const std::vector<std::string>& env,
            const fs::path& cwd, const fs::path& out, const fs::path& err) {
  std::vector<std::string> arg_storage = args, env_storage = env;
  std::vector<char*> argv, envp;
  for (std::string& s : arg_storage) argv.push_back(s.data());
  argv.push_back(nullptr);
  for (std::string& s : env_storage) envp.push_back(s.data());
  envp.push_back(nullptr);
  const std::string out_path = out.empty() ? "/dev/null" : out.string();
  const std::string err_path = err.empty() ? "/dev/null" : err.string();
  const std::string dir = cwd.string();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // Child: only async-signal-safe calls until exec.
    const int in = ::open("/dev/null", O_RDONLY);
    const int o = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int e = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (in < 0 || o < 0 || e < 0 || ::chdir(dir.c_str()) != 0 || ::dup2(in, 0) < 0 ||
        ::dup2(o, 1) < 0 || ::dup2(e, 2) < 0) {
      ::_exit(126);
    }
    ::execvpe(argv[0], argv.data(), envp.data());
    ::_exit(127);
  }
  return pid;
}

// Waits up to `timeout` for `pid` to exit; its exit code, 128 + signal, or nullopt on timeout.
std::optional<int> WaitExit(pid_t pid, std::chrono::milliseconds timeout) {
  const Clock::time_point end = Clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) {
      if (WIFEXITED(status)) return WEXITSTATUS(status);
      if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
    }
    if (r < 0 && errno != EINTR) return std::nullopt;
    if (Clock::now() > end) return std::nullopt;
    std::this_thread::sleep_for(10ms);
  }
}

void KillAndReap(pid_t pid) {
  if (pid <= 0) return;
  ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// A scratch folder, removed at the end.
class TempFolder {
 public:
  TempFolder() {
    std::string pattern = (fs::temp_directory_path() / "tritrace_view_test.XXXXXX").string();
    if (::mkdtemp(pattern.data()) != nullptr) path_ = pattern;
  }
  ~TempFolder() {
    std::error_code ec;
    if (!path_.empty()) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// Runs a command to completion (at most `timeout`) in `cwd`.
RunResult RunCommand(const std::vector<std::string>& args, const std::vector<std::string>& env,
                     const fs::path& cwd, std::chrono::milliseconds timeout = 60s) {
  TempFolder capture;
  RunResult r;
  const pid_t pid = Spawn(args, env, cwd, capture.path() / "out", capture.path() / "err");
  if (pid < 0) return r;
  const std::optional<int> code = WaitExit(pid, timeout);
  if (!code) KillAndReap(pid);
  r.exit_code = code.value_or(-1);
  r.out = ReadFile(capture.path() / "out");
  r.err = ReadFile(capture.path() / "err");
  return r;
}

// An X server of its own, so that tests can run in parallel. Xvfb's own choice of a free display
// (-displayfd alone) scans up from :0, so tests starting together would race for the same low
// numbers; each try here names a number spread over a wide range by the process id, and
// -displayfd still reports when the server accepts connections. A taken number makes Xvfb exit at
// once, and the next try takes another.
class Xvfb {
 public:
  Xvfb() {
    for (int attempt = 0; attempt < 8 && display_.empty(); ++attempt) {
      const int number = 1000 + static_cast<int>((static_cast<unsigned>(::getpid()) * 7919u +
                                                  static_cast<unsigned>(attempt) * 104729u) %
                                                 30000u);
      Start(number);
    }
  }
  ~Xvfb() { Stop(); }
  const std::string& display() const { return display_; }  // empty: not started

 private:
  void Start(int number) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return;
    const std::string write_fd = std::to_string(fds[1]);
    std::string name = ":";
    name += std::to_string(number);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::fcntl(fds[1], F_SETFD, 0);  // the write end must survive exec
      const int null = ::open("/dev/null", O_RDWR);
      if (null >= 0) {
        ::dup2(null, 0);
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      ::execlp("Xvfb", "Xvfb", name.c_str(), "-displayfd", write_fd.c_str(), "-screen", "0",
               "1280x1024x24", "-nolisten", "tcp", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(fds[1]);
    if (pid_ < 0) {
      ::close(fds[0]);
      return;
    }
    std::string reported;
    const Clock::time_point end = Clock::now() + 15s;
    while (Clock::now() < end) {
      pollfd p{fds[0], POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char c = 0;
      if (::read(fds[0], &c, 1) != 1) break;  // Xvfb exited: it could not start
      if (c == '\n') {
        display_ = ":" + reported;
        break;
      }
      reported += c;
    }
    ::close(fds[0]);
    if (display_.empty()) Stop();
  }
  void Stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      if (!WaitExit(pid_, 5s)) KillAndReap(pid_);
    }
    pid_ = -1;
  }

  pid_t pid_ = -1;
  std::string display_;
};

const std::string kNoDisplayLine =
    "tritrace-view: no display available (set DISPLAY or use 'tritrace render')\n";

// One running viewer in its own folder on its own X server.
class ViewerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(work_.path().empty());
    xvfb_ = std::make_unique<Xvfb>();
    if (xvfb_->display().empty()) GTEST_SKIP() << "skipped: no Xvfb";
    env_ = Environment(xvfb_->display());
    // Xvfb names its display once it listens; a client's first request is the proof that it
    // serves, so the viewer's own start is not also a test of the server's.
    bool serving = false;
    for (const Clock::time_point end = Clock::now() + 10s; !serving && Clock::now() < end;) {
      serving =
          RunCommand({"xdotool", "getdisplaygeometry"}, env_, work_.path(), 5s).exit_code == 0;
      if (!serving) std::this_thread::sleep_for(50ms);
    }
    ASSERT_TRUE(serving) << "Xvfb on " << xvfb_->display() << " does not answer";
  }

  void TearDown() override {
    KillAndReap(viewer_);
    xvfb_.reset();
  }

  void StartViewer(const std::vector<std::string>& flags) {
    std::vector<std::string> args{TRITRACE_VIEW_PATH};
    args.insert(args.end(), flags.begin(), flags.end());
    viewer_ =
        Spawn(args, env_, work_.path(), work_.path() / "viewer.out", work_.path() / "viewer.err");
    ASSERT_GT(viewer_, 0);
    start_ = Clock::now();
    // The window exists once xdotool finds it by the viewer's pid (SDL sets _NET_WM_PID).
    const Clock::time_point end = Clock::now() + 20s;
    while (window_.empty() && Clock::now() < end) {
      const RunResult r = RunCommand({"xdotool", "search", "--pid", std::to_string(viewer_)}, env_,
                                     work_.path(), 10s);
      if (!Words(r.out).empty()) window_ = Words(r.out).front();
      if (window_.empty()) std::this_thread::sleep_for(50ms);
      ASSERT_FALSE(WaitExit(viewer_, 0ms).has_value()) << "the viewer exited: " << Err();
    }
    ASSERT_FALSE(window_.empty()) << "no window for the viewer; stderr: " << Err();
    // Key presses go to the window with the input focus; with no window manager, give it.
    ASSERT_EQ(Xdotool({"windowfocus", "--sync", window_}), 0);
  }

  int Xdotool(std::vector<std::string> args) {
    args.insert(args.begin(), "xdotool");
    return RunCommand(args, env_, work_.path(), 10s).exit_code;
  }

  void Key(const std::string& key) { ASSERT_EQ(Xdotool({"key", key}), 0); }
  void Hold(const std::string& key, std::chrono::milliseconds how_long) {
    ASSERT_EQ(Xdotool({"keydown", key}), 0);
    std::this_thread::sleep_for(how_long);
    ASSERT_EQ(Xdotool({"keyup", key}), 0);
  }

  std::string Out() const { return ReadFile(work_.path() / "viewer.out"); }
  std::string Err() const { return ReadFile(work_.path() / "viewer.err"); }

  // The stdout lines starting with `prefix`, once there are at least `count` (empty on timeout).
  std::vector<std::string> WaitForLines(const std::string& prefix, size_t count) {
    const Clock::time_point end = Clock::now() + 20s;
    for (;;) {
      std::vector<std::string> found;
      for (const std::string& line : Lines(Out())) {
        if (line.rfind(prefix, 0) == 0) found.push_back(line);
      }
      if (found.size() >= count) return found;
      if (Clock::now() > end || WaitExit(viewer_, 0ms).has_value()) {
        ADD_FAILURE() << "waited for " << count << " '" << prefix << "' lines; stdout:\n"
                      << Out() << "stderr:\n"
                      << Err();
        return {};
      }
      std::this_thread::sleep_for(20ms);
    }
  }

  struct Shot {
    fs::path path;
    std::vector<std::string> command;  // the words after "tritrace"
    tritrace::Rgb8Image image;
  };

  // Presses P and returns the screenshot it saved (the `n`th) with its reproducing command.
  Shot Screenshot(size_t n) {
    Key("p");
    Shot shot;
    const std::vector<std::string> lines = WaitForLines("saved ", n);
    if (lines.size() < n) return shot;
    const std::string& line = lines[n - 1];
    const size_t colon = line.find(": tritrace render ");
    EXPECT_NE(colon, std::string::npos) << line;
    if (colon == std::string::npos) return shot;
    shot.path = line.substr(6, colon - 6);
    EXPECT_TRUE(shot.path.is_absolute()) << shot.path;
    EXPECT_EQ(shot.path.parent_path(), fs::canonical(work_.path()));
    shot.command = Words(line.substr(colon + 11));
    shot.image = tritrace::read_image_rgb8(shot.path.string());
    return shot;
  }

  // `tritrace <command> -o NAME -q` in the viewer's folder, decoded.
  tritrace::Rgb8Image RenderWithCli(std::vector<std::string> command, const std::string& name) {
    command.insert(command.begin(), TRITRACE_CLI_PATH);
    command.insert(command.end(), {"-o", name, "-q"});
    const RunResult r = RunCommand(command, env_, work_.path());
    EXPECT_EQ(r.exit_code, 0) << r.err;
    if (r.exit_code != 0) return {};
    return tritrace::read_image_rgb8((work_.path() / name).string());
  }

  // The value after `flag` in a screenshot's command.
  static std::string Value(const Shot& shot, const std::string& flag) {
    for (size_t i = 0; i + 1 < shot.command.size(); ++i) {
      if (shot.command[i] == flag) return shot.command[i + 1];
    }
    ADD_FAILURE() << flag << " missing";
    return "";
  }

  // What a window manager sends when the user clicks the close button: WM_DELETE_WINDOW.
  void CloseWindow() {
    Display* x = XOpenDisplay(xvfb_->display().c_str());
    ASSERT_NE(x, nullptr);
    XEvent close{};
    close.xclient.type = ClientMessage;
    close.xclient.window = static_cast<Window>(std::stoul(window_));
    close.xclient.message_type = XInternAtom(x, "WM_PROTOCOLS", False);
    close.xclient.format = 32;
    close.xclient.data.l[0] = static_cast<long>(XInternAtom(x, "WM_DELETE_WINDOW", False));
    close.xclient.data.l[1] = CurrentTime;
    XSendEvent(x, close.xclient.window, False, NoEventMask, &close);
    XCloseDisplay(x);  // flushes the event
  }

  // The window's title, as a window manager shows it (_NET_WM_NAME, UTF-8).
  std::string Title() {
    std::string title =
        RunCommand({"xdotool", "getwindowname", window_}, env_, work_.path(), 10s).out;
    while (!title.empty() && title.back() == '\n') title.pop_back();
    return title;
  }

  // The path tracer's samples so far and target from the title's "N/T spp"; nullopt when the title
  // shows none (yet).
  std::optional<std::pair<int, int>> TitleSpp() {
    const std::string title = Title();
    const size_t spp = title.find(" spp");
    if (spp == std::string::npos) return std::nullopt;
    const size_t start = title.rfind(' ', spp - 1);
    const size_t slash = title.find('/', start);
    if (start == std::string::npos || slash == std::string::npos || slash > spp)
      return std::nullopt;
    return std::pair(std::stoi(title.substr(start + 1, slash - start - 1)),
                     std::stoi(title.substr(slash + 1, spp - slash - 1)));
  }

  // Polls the title until the samples so far satisfy `ok` (nullopt after `timeout`).
  template <typename Ok>
  std::optional<int> WaitForSpp(Ok ok, std::chrono::milliseconds timeout = 30s) {
    const Clock::time_point end = Clock::now() + timeout;
    while (Clock::now() < end && !WaitExit(viewer_, 0ms).has_value()) {
      const std::optional<std::pair<int, int>> spp = TitleSpp();
      if (spp && ok(spp->first)) return spp->first;
      std::this_thread::sleep_for(20ms);
    }
    ADD_FAILURE() << "title '" << Title() << "'; stderr: " << Err();
    return std::nullopt;
  }

  // Polls the title until `ok` holds (false after `timeout`).
  template <typename Ok>
  bool WaitForTitle(Ok ok, std::chrono::milliseconds timeout = 30s) {
    for (const Clock::time_point end = Clock::now() + timeout; Clock::now() < end;) {
      if (ok(Title())) return true;
      if (WaitExit(viewer_, 0ms).has_value()) return false;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }

  // Whether `shot`'s command has `flag` (a flag without a value).
  static bool HasFlag(const Shot& shot, const std::string& flag) {
    return std::find(shot.command.begin(), shot.command.end(), flag) != shot.command.end();
  }

  // utime + stime of the viewer, in seconds.
  double CpuSeconds() const {
    const std::string stat = ReadFile("/proc/" + std::to_string(viewer_) + "/stat");
    // Fields after the command name (which is in parentheses and may hold spaces): state is
    // field 3, utime 14 and stime 15.
    const std::vector<std::string> f = Words(stat.substr(stat.rfind(')') + 1));
    if (f.size() < 13) return -1.0;
    const double ticks = std::stod(f[11]) + std::stod(f[12]);
    return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }

  TempFolder work_;
  std::unique_ptr<Xvfb> xvfb_;
  std::vector<std::string> env_;
  pid_t viewer_ = -1;
  std::string window_;
  Clock::time_point start_;
};

bool SameImage(const tritrace::Rgb8Image& a, const tritrace::Rgb8Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb == b.rgb;
}

TEST_F(ViewerTest, KeysMoveTheViewAndEveryScreenshotIsTheCliImage) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--width", "200", "--height", "160", "--print-state"}));
  ASSERT_FALSE(WaitForLines("view: ", 1).empty());

  // H draws the overlay in the window only: the screenshot is still the rendered image.
  Key("h");
  const Shot first = Screenshot(1);
  ASSERT_EQ(first.image.width, 200);
  ASSERT_EQ(first.image.height, 160);
  EXPECT_EQ(Value(first, "--yaw"), "0");
  EXPECT_EQ(Value(first, "--distance"), "3");
  EXPECT_EQ(Value(first, "--light"), "0,-0.5,-0.7");
  EXPECT_TRUE(SameImage(first.image, RenderWithCli(first.command, "cli1.png")));

  // Held Left orbits the camera (adding yaw) for as long as it is held.
  Hold("Left", 500ms);
  const Shot turned = Screenshot(2);
  const double yaw = std::stod(Value(turned, "--yaw"));
  EXPECT_GT(yaw, 0.3) << "1.5 rad/s held for 0.5 s";
  EXPECT_LT(yaw, 3.0);  // generous: a loaded machine delays the key release
  EXPECT_TRUE(SameImage(turned.image, RenderWithCli(turned.command, "cli2.png")));
  EXPECT_FALSE(SameImage(turned.image, first.image));

  // W moves the light toward +z: the shadows move.
  Hold("w", 300ms);
  const Shot lit = Screenshot(3);
  EXPECT_EQ(Value(lit, "--yaw"), Value(turned, "--yaw"));
  const std::vector<std::string> light = Words([&] {
    std::string l = Value(lit, "--light");
    for (char& c : l) c = c == ',' ? ' ' : c;
    return l;
  }());
  ASSERT_EQ(light.size(), 3u);
  EXPECT_EQ(light[0], "0");
  EXPECT_EQ(light[1], "-0.5");
  EXPECT_GT(std::stod(light[2]), -0.65);
  EXPECT_TRUE(SameImage(lit.image, RenderWithCli(lit.command, "cli3.png")));
  EXPECT_FALSE(SameImage(lit.image, turned.image));

  // Up moves the camera forward (closer), Down back.
  Hold("Up", 300ms);
  const Shot closer = Screenshot(4);
  EXPECT_LT(std::stod(Value(closer, "--distance")), 2.9);
  EXPECT_TRUE(SameImage(closer.image, RenderWithCli(closer.command, "cli4.png")));
  EXPECT_FALSE(SameImage(closer.image, lit.image));
  Hold("Down", 600ms);
  const Shot farther = Screenshot(5);
  EXPECT_GT(std::stod(Value(farther, "--distance")), std::stod(Value(closer, "--distance")));
  EXPECT_TRUE(SameImage(farther.image, RenderWithCli(farther.command, "cli5.png")));

  // R resets camera and light: the first image again.
  Key("r");
  const Shot reset = Screenshot(6);
  EXPECT_TRUE(SameImage(reset.image, first.image));

  // A resized window renders at its new size.
  ASSERT_EQ(Xdotool({"windowsize", window_, "120", "90"}), 0);
  const Clock::time_point resize_end = Clock::now() + 10s;
  Shot resized;
  for (size_t n = 7; Clock::now() < resize_end; ++n) {
    resized = Screenshot(n);
    if (resized.image.width == 120 || ::testing::Test::HasFailure()) break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(resized.image.width, 120);
  EXPECT_EQ(resized.image.height, 90);
  EXPECT_TRUE(SameImage(resized.image, RenderWithCli(resized.command, "cli7.png")));

  Key("Escape");
  const std::optional<int> code = WaitExit(viewer_, 10s);
  viewer_ = -1;
  EXPECT_EQ(code, 0) << Err();
  EXPECT_EQ(Err(), "");

  // The lab's "Render time" line, at most once a second (and once for the first frame).
  const double seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  const size_t reports = WaitForLines("Render time: ", 1).size();
  EXPECT_LE(static_cast<double>(reports), seconds + 1.0) << Out();
}

TEST_F(ViewerTest, IdleViewerUsesAlmostNoCpu) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--width", "100", "--height", "100", "--print-state"}));
  ASSERT_FALSE(WaitForLines("view: ", 1).empty());
  std::this_thread::sleep_for(1200ms);  // past the first "Render time" line's one-second window
  const double cpu_before = CpuSeconds();
  const Clock::time_point wall_before = Clock::now();
  std::this_thread::sleep_for(2s);
  const double cpu = CpuSeconds() - cpu_before;
  const double wall = std::chrono::duration<double>(Clock::now() - wall_before).count();
  EXPECT_LT(cpu, 0.05 * wall) << "CPU seconds while idle for " << wall << " s";
}

// The path tracer in the window: while the view rests each frame adds samples to the film and the
// title counts them; a key that moves the view starts the film over.
TEST_F(ViewerTest, PathTracerAccumulatesWhileRestingAndAKeyRestarts) {
  ASSERT_NO_FATAL_FAILURE(StartViewer(
      {"--scene", "cornell-area", "--width", "160", "--height", "120", "--spp", "100000", "-q"}));
  const std::optional<int> first = WaitForSpp([](int spp) { return spp >= 1; });
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(TitleSpp()->second, 100000) << Title();
  // Two seconds of rest: the count grows (at any speed a machine has, by far more than one
  // frame's).
  std::this_thread::sleep_for(2s);
  const int before = TitleSpp()->first;
  EXPECT_GT(before, *first + 2) << Title();

  // Left held turns the view: the film restarts at one sample, and half a second after the key is
  // released holds about a quarter of the two seconds' samples. The smallest count seen right
  // after the key is far below the count before it. (Held for longer than a frame: the viewer
  // reads which keys are down once a frame.)
  Hold("Left", 300ms);
  int least = before;
  for (const Clock::time_point end = Clock::now() + 500ms; Clock::now() < end;) {
    if (const std::optional<std::pair<int, int>> spp = TitleSpp())
      least = std::min(least, spp->first);
  }
  EXPECT_LT(least, before / 2) << "before the key: " << before;
  // And it accumulates again.
  EXPECT_TRUE(WaitForSpp([&](int spp) { return spp > least; }).has_value());
}

// N turns the denoiser on: once the view rests the title says which samples the denoised image
// holds; N again turns it off and the title no longer mentions it.
TEST_F(ViewerTest, NDenoisesTheRestingPathImageAndSaysSoInTheTitle) {
  ASSERT_NO_FATAL_FAILURE(StartViewer(
      {"--scene", "cornell-area", "--width", "96", "--height", "72", "--spp", "64", "-q"}));
  ASSERT_TRUE(WaitForSpp([](int spp) { return spp >= 1; }).has_value());
  EXPECT_EQ(Title().find("denoise"), std::string::npos) << Title();
  Key("n");
  const auto wait_title = [&](auto ok) {
    for (const Clock::time_point end = Clock::now() + 30s; Clock::now() < end;) {
      if (ok(Title())) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  };
  EXPECT_TRUE(wait_title([](const std::string& t) {
    return t.find(", denoised at ") != std::string::npos;
  })) << Title()
      << "; stderr: " << Err();
  // At rest it ends with the whole film denoised.
  EXPECT_TRUE(wait_title([](const std::string& t) {
    return t.find("64/64 spp") != std::string::npos &&
           t.find("denoised at 64 spp") != std::string::npos;
  })) << Title();
  Key("n");
  EXPECT_TRUE(wait_title([](const std::string& t) {
    return t.find("64/64 spp") != std::string::npos && t.find("denoise") == std::string::npos;
  })) << Title();
}

// Screenshots of the path tracer are the running mean through the sRGB curve, and the printed
// command renders the same file byte for byte at the samples it names: the film of samples
// [0, N) added frame by frame is the film `tritrace render --spp N` makes. Seed and filter given
// here travel into the command.
TEST_F(ViewerTest, PathScreenshotsAreTheCliImageAtTheirSamples) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "cornell-area", "--width", "64", "--height", "48", "--spp", "300",
                   "--seed", "7", "--filter", "gaussian", "-q", "--print-state"}));
  ASSERT_FALSE(WaitForLines("view: ", 1).empty());
  ASSERT_TRUE(WaitForSpp([](int spp) { return spp >= 1; }).has_value());
  // Whatever the count is at this moment (mid-accumulation on most machines).
  const Shot early = Screenshot(1);
  ASSERT_FALSE(early.command.empty());
  EXPECT_EQ(Value(early, "--integrator"), "path");
  EXPECT_EQ(Value(early, "--seed"), "7");
  EXPECT_EQ(Value(early, "--filter"), "gaussian");
  const int early_spp = std::stoi(Value(early, "--spp"));
  EXPECT_GE(early_spp, 1);
  EXPECT_LE(early_spp, 300);
  RenderWithCli(early.command, "cli1.png");
  EXPECT_EQ(ReadFile(early.path), ReadFile(work_.path() / "cli1.png")) << "at " << early_spp;

  // Converged: the first frame took one sample, so the film was added up over several frames.
  ASSERT_TRUE(WaitForSpp([](int spp) { return spp == 300; }).has_value());
  const Shot done = Screenshot(2);
  EXPECT_EQ(Value(done, "--spp"), "300");
  const tritrace::Rgb8Image cli = RenderWithCli(done.command, "cli2.png");
  EXPECT_EQ(ReadFile(done.path), ReadFile(work_.path() / "cli2.png"));
  EXPECT_TRUE(SameImage(done.image, cli));
  // The ceiling light, seen from below, is radiance 10: white through the sRGB curve.
  // It spans rows 7 to 9 at the middle of this image (the ceiling y = -1 at depth z in
  // [-0.18, 0.2] from the camera at z = -3 with focal length 48 seen at rows 24 - 48 / (z + 3)).
  const size_t light = 3 * (8 * 64 + 32);
  EXPECT_EQ(done.image.rgb[light], 255);
  EXPECT_EQ(done.image.rgb[light + 1], 255);
  EXPECT_EQ(done.image.rgb[light + 2], 255);

  // A turned view converges to its own image, again the CLI's. Once the turned view has come to
  // rest (its "view: " line, printed after its first frame), the title counts its samples.
  Hold("Left", 300ms);
  ASSERT_FALSE(WaitForLines("view: ", 2).empty());
  ASSERT_TRUE(WaitForSpp([](int spp) { return spp == 300; }).has_value());
  const Shot turned = Screenshot(3);
  EXPECT_NE(Value(turned, "--yaw"), "0");
  RenderWithCli(turned.command, "cli3.png");
  EXPECT_EQ(ReadFile(turned.path), ReadFile(work_.path() / "cli3.png"));
  EXPECT_NE(ReadFile(turned.path), ReadFile(done.path));
}

// bdpt with --noise-threshold: its levels are whole images rendered in one part (light tracing
// splats onto every tile, docs/BDPT.md); the converged level's screenshot is the CLI's adaptive
// render of its command byte for byte.
TEST_F(ViewerTest, BdptNoiseThresholdRefinesInWholeLevelsUntilConverged) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "cornell-area", "--integrator", "bdpt", "--width", "32", "--height",
                   "24", "--spp", "1024", "--noise-threshold", "0.3", "-q"}));
  EXPECT_TRUE(WaitForTitle([](const std::string& t) {
    return t.find("stopped: converged") != std::string::npos;
  })) << Title()
      << "; stderr: " << Err();
  const Shot shot = Screenshot(1);
  ASSERT_FALSE(shot.command.empty());
  EXPECT_EQ(Value(shot, "--integrator"), "bdpt");
  EXPECT_EQ(Value(shot, "--noise-threshold"), "0.3");
  RenderWithCli(shot.command, "cli.png");
  EXPECT_EQ(ReadFile(shot.path), ReadFile(work_.path() / "cli.png"));
}

// With --noise-threshold the resting view is refined in whole adaptive images of 128, 256, ...
// spp, each a few tiles a frame, until a level stops every pixel before its end: the title says
// "stopped: converged", and the screenshot's command (with --noise-threshold and the level's spp)
// renders the same file byte for byte. The last level is the first that is more than every
// pixel's samples in the CLI's adaptive render of the same view (its spp layer): there every pixel
// stopped before the level's end. The same with the denoiser on: each level's film denoised as
// `render --denoise` denoises it.
TEST_F(ViewerTest, NoiseThresholdRefinesInAdaptiveLevelsUntilConverged) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--scene", "cornell-area", "--width", "64", "--height", "48",
                                       "--spp", "4096", "--noise-threshold", "0.3", "-q"}));
  EXPECT_TRUE(WaitForTitle([](const std::string& t) {
    return t.find("stopped: converged") != std::string::npos;
  })) << Title()
      << "; stderr: " << Err();
  const RunResult cli = RunCommand(
      {TRITRACE_CLI_PATH, "render", "--scene", "cornell-area", "--width", "64", "--height", "48",
       "--spp", "4096", "--noise-threshold", "0.3", "--aovs", "spp", "-o", "spp.exr", "-q"},
      env_, work_.path());
  ASSERT_EQ(cli.exit_code, 0) << cli.err;
  const std::array<std::string, 3> spp_layer{"spp", "spp", "spp"};
  const std::vector<tritrace::Image> spp =
      tritrace::read_exr_layers((work_.path() / "spp.exr").string(), {&spp_layer, 1});
  ASSERT_EQ(spp.size(), 1u);
  float most = 0.0f;
  for (const glm::vec3& s : spp[0].pixels()) most = std::max(most, s.x);
  int level = 128;
  while (static_cast<float>(level) <= most) level *= 2;
  ASSERT_LT(level, 4096) << "the view must converge before --spp for this test";
  const std::string level_text = std::to_string(level);
  const std::string title = Title();
  EXPECT_NE(title.find(", " + level_text + "/4096 spp, "), std::string::npos) << title;
  EXPECT_NE(title.find("noise threshold 0.3"), std::string::npos) << title;
  const Shot shot = Screenshot(1);
  ASSERT_FALSE(shot.command.empty());
  EXPECT_EQ(Value(shot, "--spp"), level_text);
  EXPECT_EQ(Value(shot, "--noise-threshold"), "0.3");
  RenderWithCli(shot.command, "cli.png");
  EXPECT_EQ(ReadFile(shot.path), ReadFile(work_.path() / "cli.png"));
  // Stopped: no more samples, and the view sleeps.
  std::this_thread::sleep_for(300ms);
  const double cpu_before = CpuSeconds();
  std::this_thread::sleep_for(1s);
  EXPECT_LT(CpuSeconds() - cpu_before, 0.1);
  EXPECT_EQ(TitleSpp()->first, level);
  EXPECT_FALSE(HasFlag(shot, "--denoise"));

  // N: the film starts over with the denoiser's features and is refined to the same level.
  Key("n");
  EXPECT_TRUE(WaitForTitle([&](const std::string& t) {
    return t.find("denoised at " + level_text + " spp, stopped: converged") != std::string::npos;
  })) << Title();
  const Shot denoised = Screenshot(2);
  ASSERT_FALSE(denoised.command.empty());
  EXPECT_TRUE(HasFlag(denoised, "--denoise"));
  EXPECT_EQ(Value(denoised, "--spp"), level_text);
  RenderWithCli(denoised.command, "cli_denoised.png");
  EXPECT_EQ(ReadFile(denoised.path), ReadFile(work_.path() / "cli_denoised.png"));
  EXPECT_NE(ReadFile(denoised.path), ReadFile(shot.path));
}

// --time-limit stops refinement that long after the view comes to rest, also in the middle of an
// adaptive level (which is dropped: the image stays the last whole level, the CLI's at its spp);
// moving the view starts over, and the limit stops it again.
TEST_F(ViewerTest, TimeLimitStopsRefinementAndAKeyRestartsIt) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "cornell-area", "--width", "64", "--height", "48",
                   "--noise-threshold", "0.002", "--time-limit", "1.5", "-q", "--print-state"}));
  ASSERT_FALSE(WaitForLines("view: ", 1).empty());
  const auto stopped = [](const std::string& t) {
    return t.find("stopped: time limit") != std::string::npos;
  };
  EXPECT_TRUE(WaitForTitle(stopped)) << Title() << "; stderr: " << Err();
  // Without --spp the most is the CLI's for --time-limit, 2^24.
  const std::optional<std::pair<int, int>> spp = TitleSpp();
  ASSERT_TRUE(spp.has_value());
  EXPECT_EQ(spp->second, 16777216);
  EXPECT_GE(spp->first, 1);
  const Shot shot = Screenshot(1);
  ASSERT_FALSE(shot.command.empty());
  EXPECT_EQ(Value(shot, "--spp"), std::to_string(spp->first));
  EXPECT_EQ(Value(shot, "--noise-threshold"), "0.002");
  RenderWithCli(shot.command, "cli.png");
  EXPECT_EQ(ReadFile(shot.path), ReadFile(work_.path() / "cli.png")) << "at " << spp->first;
  std::this_thread::sleep_for(500ms);
  EXPECT_EQ(TitleSpp()->first, spp->first) << "no samples after the limit";

  Hold("Left", 300ms);
  ASSERT_FALSE(WaitForLines("view: ", 2).empty());
  EXPECT_TRUE(WaitForTitle([&](const std::string& t) { return !stopped(t); }, 5s)) << Title();
  EXPECT_TRUE(WaitForTitle(stopped)) << Title();
}

// --denoise starts with the denoiser on; the resting image is `tritrace render --denoise`'s, and
// the screenshot's command says --denoise.
TEST_F(ViewerTest, DenoisedScreenshotIsTheCliDenoisedImage) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--scene", "cornell-area", "--width", "48", "--height", "40",
                                       "--spp", "32", "--denoise", "-q", "--print-state"}));
  // The view's command: the image it converges to is denoised.
  const std::vector<std::string> view = WaitForLines("view: ", 1);
  ASSERT_FALSE(view.empty());
  EXPECT_NE(view[0].find(" --spp 32 --seed 0 --denoise"), std::string::npos) << view[0];
  EXPECT_TRUE(WaitForTitle([](const std::string& t) {
    return t.find("32/32 spp") != std::string::npos &&
           t.find("denoised at 32 spp") != std::string::npos &&
           t.find("stopped: spp reached") != std::string::npos;
  })) << Title()
      << "; stderr: " << Err();
  const Shot shot = Screenshot(1);
  ASSERT_FALSE(shot.command.empty());
  EXPECT_TRUE(HasFlag(shot, "--denoise"));
  RenderWithCli(shot.command, "cli.png");
  EXPECT_EQ(ReadFile(shot.path), ReadFile(work_.path() / "cli.png"));
  // N turns it off: the next screenshot is the noisy film, without --denoise.
  Key("n");
  EXPECT_TRUE(WaitForTitle([](const std::string& t) {
    return t.find("denoise") == std::string::npos;
  })) << Title();
  const Shot plain = Screenshot(2);
  EXPECT_FALSE(HasFlag(plain, "--denoise"));
  EXPECT_NE(ReadFile(plain.path), ReadFile(shot.path));
}

// bdpt takes --denoise and --time-limit as path does (README): the resting image is denoised,
// the title says so and says the limit stopped it, and the screenshot is `tritrace render
// --integrator bdpt --denoise` of its samples byte for byte.
TEST_F(ViewerTest, BdptDenoisesAndStopsAtTheTimeLimit) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "cornell-area", "--integrator", "bdpt", "--width", "32", "--height",
                   "24", "--time-limit", "0.5", "--denoise", "-q"}));
  EXPECT_TRUE(WaitForTitle([](const std::string& t) {
    return t.find("stopped: time limit") != std::string::npos &&
           t.find("denoised at ") != std::string::npos;
  })) << Title()
      << "; stderr: " << Err();
  const Shot shot = Screenshot(1);
  ASSERT_FALSE(shot.command.empty());
  EXPECT_EQ(Value(shot, "--integrator"), "bdpt");
  EXPECT_TRUE(HasFlag(shot, "--denoise"));
  RenderWithCli(shot.command, "cli.png");
  EXPECT_EQ(ReadFile(shot.path), ReadFile(work_.path() / "cli.png")) << Value(shot, "--spp");
}

// The path tracer's settings mean nothing to the lab integrator: refused as `tritrace render`
// refuses them.
TEST_F(ViewerTest, PathSettingsWithTheLabIntegratorAreUsageErrors) {
  for (const auto& [flags, line] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--time-limit", "2"},
            "tritrace-view: --time-limit: applies to the path tracer; the lab integrator takes one "
            "sample per pixel\n"},
           {{"--noise-threshold", "0.1"},
            "tritrace-view: --noise-threshold: applies to the path tracer; the lab integrator "
            "takes one sample per pixel\n"},
           {{"--denoise"},
            "tritrace-view: --denoise: applies to the path tracer; the lab integrator's image has "
            "no noise\n"},
       }) {
    std::vector<std::string> args{TRITRACE_VIEW_PATH, "--width", "32", "--height", "32"};
    args.insert(args.end(), flags.begin(), flags.end());
    const RunResult r = RunCommand(args, env_, work_.path(), 30s);
    EXPECT_EQ(r.exit_code, 2) << line;
    EXPECT_EQ(r.err, line);
  }
}

// Once the film has the scene's samples, the path tracer stops and the viewer sleeps like the
// lab's.
TEST_F(ViewerTest, IdlePathTracerUsesAlmostNoCpuOnceConverged) {
  ASSERT_NO_FATAL_FAILURE(StartViewer(
      {"--scene", "cornell-area", "--width", "100", "--height", "100", "--spp", "32", "-q"}));
  ASSERT_TRUE(WaitForSpp([](int spp) { return spp == 32; }).has_value());
  std::this_thread::sleep_for(300ms);
  const double cpu_before = CpuSeconds();
  const Clock::time_point wall_before = Clock::now();
  std::this_thread::sleep_for(2s);
  const double cpu = CpuSeconds() - cpu_before;
  const double wall = std::chrono::duration<double>(Clock::now() - wall_before).count();
  EXPECT_LT(cpu, 0.05 * wall) << "CPU seconds while idle for " << wall << " s";
  EXPECT_EQ(TitleSpp()->first, 32);
}

// --benchmark-frames turns the view every frame, so the path tracer renders one sample a frame.
TEST_F(ViewerTest, BenchmarkFramesWithThePathTracer) {
  const RunResult r = RunCommand({TRITRACE_VIEW_PATH, "--scene", "cornell-area", "--width", "64",
                                  "--height", "64", "--benchmark-frames", "5"},
                                 env_, work_.path());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("benchmark: 5 frames at 64x64, medians: frame ", 0), 0u) << r.out;
}

TEST_F(ViewerTest, ClosingTheWindowQuitsWithExitZero) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--width", "64", "--height", "64", "-q"}));
  ASSERT_NO_FATAL_FAILURE(CloseWindow());
  const std::optional<int> code = WaitExit(viewer_, 10s);
  viewer_ = -1;
  EXPECT_EQ(code, 0) << Err();
  EXPECT_EQ(Err(), "");
}

// A scene that takes a second or more to make and build: the window is there at once, and its
// title shows the phases (the words of `tritrace render`'s phase line) with their times, then the
// first frame's title.
TEST_F(ViewerTest, WindowOpensAtOnceAndShowsTheLoadingPhases) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "terrain:2m", "--width", "64", "--height", "64", "-q"}));
  std::vector<std::string> titles;
  const Clock::time_point end = Clock::now() + 120s;
  while (Clock::now() < end) {
    const std::string title = Title();
    if (titles.empty() || titles.back() != title) titles.push_back(title);
    if (title.find(" ms") != std::string::npos) break;  // the first frame's "12.3 ms, ..." title
    ASSERT_FALSE(WaitExit(viewer_, 0ms).has_value()) << "the viewer exited: " << Err();
    std::this_thread::sleep_for(20ms);
  }
  std::string seen;
  for (const std::string& t : titles) seen += "\n  " + t;
  const auto shows = [&](const std::string& prefix) {
    return std::any_of(titles.begin(), titles.end(),
                       [&](const std::string& t) { return t.rfind(prefix, 0) == 0; });
  };
  EXPECT_TRUE(shows("tritrace \u2014 making terrain:2m  ") ||
              shows("tritrace \u2014 building bvh over 2000000 triangles  "))
      << "titles seen:" << seen;
  ASSERT_FALSE(titles.empty());
  EXPECT_NE(titles.back().find(" ms"), std::string::npos) << "no frame; titles seen:" << seen;
}

// Closing the window while the scene still loads ends the process at once with exit 0.
TEST_F(ViewerTest, ClosingWhileLoadingQuitsWithExitZero) {
  ASSERT_NO_FATAL_FAILURE(
      StartViewer({"--scene", "terrain:4m", "--width", "64", "--height", "64", "-q"}));
  const std::string title = Title();
  ASSERT_NO_FATAL_FAILURE(CloseWindow());
  const Clock::time_point sent = Clock::now();
  const std::optional<int> code = WaitExit(viewer_, 60s);
  viewer_ = -1;
  EXPECT_EQ(code, 0) << Err();
  EXPECT_EQ(Err(), "");
  // Closed during a phase (the title said so), it did not wait for the load to end.
  EXPECT_TRUE(title.rfind("tritrace \u2014 making", 0) == 0 ||
              title.rfind("tritrace \u2014 building", 0) == 0)
      << title;
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - sent).count(), 2.0) << title;
}

TEST_F(ViewerTest, TerminationIsAQuitWithExitZero) {
  ASSERT_NO_FATAL_FAILURE(StartViewer({"--width", "64", "--height", "64", "-q"}));
  ::kill(viewer_, SIGTERM);  // SDL turns it into SDL_QUIT, as closing the window does
  const std::optional<int> code = WaitExit(viewer_, 10s);
  viewer_ = -1;
  EXPECT_EQ(code, 0) << Err();
  EXPECT_EQ(Out(), "");  // -q: no Render time lines
}

TEST_F(ViewerTest, MissingSceneFileIsOneLine) {
  const RunResult r = RunCommand({TRITRACE_VIEW_PATH, "missing.json"}, env_, work_.path(), 30s);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "tritrace-view: missing.json: file not found\n");
}

TEST(ViewerNoDisplay, OneLineAndExitOne) {
  TempFolder work;
  const RunResult r = RunCommand({TRITRACE_VIEW_PATH}, Environment(""), work.path(), 30s);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, kNoDisplayLine);
  EXPECT_EQ(r.out, "");
}

TEST(ViewerNoDisplay, UnreachableDisplayIsTheSameLine) {
  TempFolder work;
  const RunResult r = RunCommand({TRITRACE_VIEW_PATH}, Environment(":64999"), work.path(), 30s);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, kNoDisplayLine);
}

TEST(ViewerFlags, BadValuesNameTheFlagAndExitTwo) {
  TempFolder work;
  const std::vector<std::string> env = Environment("");
  struct Case {
    std::vector<std::string> args;
    std::string line;
  };
  for (const Case& c : std::vector<Case>{
           {{"--width", "0"},
            "tritrace-view: --width: must be an integer from 1 to 16384, got '0'"},
           {{"--distance", "-1"},
            "tritrace-view: --distance: must be a finite number greater than 0, got '-1'"},
           {{"--light", "1,2"},
            "tritrace-view: --light: must be three finite numbers X,Y,Z, got '1,2'"},
           {{"--kernel", "fast"}, "tritrace-view: --kernel: unknown kernel 'fast'"},
           {{"--bogus"}, "tritrace-view: --bogus: unknown option or argument (see --help)"},
           {{"--noise-threshold", "1"},
            "tritrace-view: --noise-threshold: must be a relative error greater than 0 and less "
            "than 1"},
           {{"--time-limit", "0"},
            "tritrace-view: --time-limit: must be a number of seconds greater than 0"},
       }) {
    std::vector<std::string> args{TRITRACE_VIEW_PATH};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const RunResult r = RunCommand(args, env, work.path(), 30s);
    EXPECT_EQ(r.exit_code, 2) << c.line;
    EXPECT_EQ(r.err.rfind(c.line, 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

TEST(ViewerFlags, TritraceViewRunsTheViewer) {
  TempFolder work;
  const RunResult bad =
      RunCommand({TRITRACE_CLI_PATH, "view", "--yaw", "x"}, Environment(""), work.path(), 30s);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_EQ(bad.err, "tritrace-view: --yaw: must be a finite number, got 'x'\n");
  const RunResult none = RunCommand({TRITRACE_CLI_PATH, "view"}, Environment(""), work.path(), 30s);
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_EQ(none.err, kNoDisplayLine);
  const RunResult help =
      RunCommand({TRITRACE_CLI_PATH, "view", "--help"}, Environment(""), work.path());
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--print-state"), std::string::npos) << help.out;
}

}  // namespace
