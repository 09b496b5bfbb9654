// CLI integration tests: run the real tritrace executable (fork/execv, no shell) in a fresh folder
// and check its exit code, stdout, stderr and the files it leaves behind.
#include <fcntl.h>
#include <gtest/gtest.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <OpenEXRConfig.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include "../image/exr_read_back.h"
#include "tritrace/accel/make_accel.h"
#if TRITRACE_HAVE_EMBREE
#include <embree3/rtcore_config.h>
#endif
#include "tritrace/image/image_io.h"

#ifndef TRITRACE_CLI_PATH
#error "TRITRACE_CLI_PATH must name the built tritrace executable"
#endif

namespace fs = std::filesystem;

namespace {

struct RunResult {
  int exit_code = -1;  // the process's exit status, or 128 + signal if it was killed
  std::string out;
  std::string err;
};

std::string MakeTempFolder() {
  std::string pattern = (fs::temp_directory_path() / "tritrace_cli_test.XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    ADD_FAILURE() << "mkdtemp failed: " << std::strerror(errno);
    return "";
  }
  return pattern;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// An EXR file's bytes with the values of the times tritrace records in the header
// (tritrace.renderSeconds, tritrace.denoiseSeconds: 4-byte floats after the name, the type and
// the size) zeroed: two renders of the same image are then the same bytes, every other attribute
// included. The times are the only part of tritrace's EXR that a clock decides.
std::string ReadExrWithoutTimes(const fs::path& path) {
  std::string bytes = ReadFile(path);
  for (const char* name : {"tritrace.renderSeconds", "tritrace.denoiseSeconds"}) {
    const std::string key = std::string(name) + std::string("\0float\0\x04\0\0\0", 11);
    const size_t at = bytes.find(key);
    if (at != std::string::npos && at + key.size() + 4 <= bytes.size()) {
      bytes.replace(at + key.size(), 4, 4, '\0');
    }
  }
  return bytes;
}

// Every entry in `folder`, hidden ones included, sorted.
std::vector<std::string> ListFolder(const fs::path& folder) {
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

size_t CountLines(const std::string& text) {
  return std::count(text.begin(), text.end(), '\n');
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = MakeTempFolder();
    capture_ = MakeTempFolder();
    ASSERT_FALSE(work_.empty());
    ASSERT_FALSE(capture_.empty());
  }

  void TearDown() override {
    std::error_code ec;
    if (!work_.empty()) {
      // Undo any permission change a test made, so that the folder can be removed.
      fs::permissions(work_, fs::perms::owner_all, fs::perm_options::add, ec);
      for (const fs::directory_entry& entry : fs::directory_iterator(work_, ec)) {
        fs::permissions(entry.path(), fs::perms::owner_all, fs::perm_options::add, ec);
      }
      fs::remove_all(work_, ec);
    }
    if (!capture_.empty()) fs::remove_all(capture_, ec);
  }

  // Runs `tritrace args...` with work_ as the current folder and stdin from /dev/null.
  RunResult Run(const std::vector<std::string>& args) const {
    const std::string out_path = (capture_ / "stdout").string();
    const std::string err_path = (capture_ / "stderr").string();
    const std::string binary = TRITRACE_CLI_PATH;
    std::vector<std::string> storage;
    storage.push_back(binary);
    storage.insert(storage.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& s : storage) argv.push_back(s.data());
    argv.push_back(nullptr);
    const std::string cwd = work_.string();

    RunResult result;
    const pid_t pid = ::fork();
    if (pid < 0) {
      ADD_FAILURE() << "fork failed: " << std::strerror(errno);
      return result;
    }
    if (pid == 0) {
      // Child: only async-signal-safe calls until execv.
      const int in = ::open("/dev/null", O_RDONLY);
      const int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      if (in < 0 || out < 0 || err < 0 || ::chdir(cwd.c_str()) != 0 || ::dup2(in, 0) < 0 ||
          ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0) {
        ::_exit(126);
      }
      ::execv(binary.c_str(), argv.data());
      ::_exit(127);
    }
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
      if (errno != EINTR) {
        ADD_FAILURE() << "waitpid failed: " << std::strerror(errno);
        return result;
      }
    }
    if (WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) result.exit_code = 128 + WTERMSIG(status);
    result.out = ReadFile(out_path);
    result.err = ReadFile(err_path);
    return result;
  }

  // Runs `tritrace render args... -q`, expects success and returns the bytes of `output`.
  std::string RenderQuietly(std::vector<std::string> args, const std::string& output) {
    args.insert(args.begin(), "render");
    args.insert(args.end(), {"-o", output, "-q"});
    const RunResult r = Run(args);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err, "");
    return ReadFile(work_ / output);
  }

  fs::path work_;     // the CLI's current folder
  fs::path capture_;  // stdout and stderr of the last run
};

// The folder holds exactly `files`: no other output and no leftover temporary file.
void ExpectOnlyFiles(const fs::path& folder, std::vector<std::string> files) {
  std::sort(files.begin(), files.end());
  EXPECT_EQ(ListFolder(folder), files);
}

// An error: one line `tritrace: <subject>: ...<reason>...` on stderr, nothing on stdout.
void ExpectErrorLine(const RunResult& r, int exit_code, const std::string& subject,
                     const std::string& reason) {
  EXPECT_EQ(r.exit_code, exit_code) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(CountLines(r.err), 1u) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.back(), '\n');
  EXPECT_EQ(r.err.rfind("tritrace: " + subject + ": ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(reason), std::string::npos) << "'" << reason << "' not in: " << r.err;
}

void ExpectRgb8Image(const fs::path& path, int width, int height) {
  ASSERT_TRUE(fs::is_regular_file(path)) << path;
  const tritrace::Rgb8Image image = tritrace::read_image_rgb8(path.string());
  EXPECT_EQ(image.width, width);
  EXPECT_EQ(image.height, height);
  EXPECT_EQ(image.rgb.size(), static_cast<size_t>(width) * height * 3);
}

// ---- Successful renders ---------------------------------------------------------------------

TEST_F(CliTest, NoArgumentsWritesA500x500CornellPngAndOneSummaryLine) {
  const RunResult r = Run({"render"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const std::regex summary(
      R"(rendered 500x500 in [0-9]+(\.[0-9]+)? ms \([0-9]+(\.[0-9]+)? Mrays/s, [0-9]+ threads?\) )"
      R"(to cornell\.png\n)");
  EXPECT_TRUE(std::regex_match(r.out, summary)) << r.out;
  ExpectOnlyFiles(work_, {"cornell.png"});
  ExpectRgb8Image(work_ / "cornell.png", 500, 500);
}

// TBB runs at most as many threads as there are cores unless told otherwise; asked for more, it
// printed "TBB Warning: The number of workers is currently limited to ..." and ran fewer. Three
// threads are more than the cores of a 2-core machine; the render (brute force, a few hundred
// milliseconds) is long enough for all three to start before the tiles run out.
TEST_F(CliTest, ThreeThreadsRunWithoutTbbWarnings) {
  const RunResult r = Run({"render", "--scene", "terrain:2k", "--accel", "brute", "--width", "160",
                           "--height", "160", "--threads", "3", "-o", "three.png"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find(", 3 threads) to three.png\n"), std::string::npos) << r.out;
}

TEST_F(CliTest, QuietFlagsPrintNothing) {
  for (const std::string flag : {"-q", "--quiet"}) {
    SCOPED_TRACE(flag);
    const RunResult r = Run({"render", "--width", "64", "--height", "64", flag});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(r.err, "");
    ExpectOnlyFiles(work_, {"cornell.png"});
    ExpectRgb8Image(work_ / "cornell.png", 64, 64);
  }
}

TEST_F(CliTest, WidthAndHeightSetTheImageSize) {
  const RunResult r = Run({"render", "--width", "64", "--height", "48", "-o", "small.png"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("rendered 64x48 in "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" to small.png\n"), std::string::npos) << r.out;
  ExpectOnlyFiles(work_, {"small.png"});
  ExpectRgb8Image(work_ / "small.png", 64, 48);
}

// 8-bit outputs, by extension, case-insensitively; both read back at the requested size.
class CliRgb8OutputTest : public CliTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(CliRgb8OutputTest, WritesAnImageOfTheRequestedSize) {
  const std::string name = GetParam();
  const RunResult r = Run({"render", "--width", "40", "--height", "30", "--output", name});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find(" to " + name + "\n"), std::string::npos) << r.out;
  ExpectOnlyFiles(work_, {name});
  ExpectRgb8Image(work_ / name, 40, 30);
}

INSTANTIATE_TEST_SUITE_P(Extensions, CliRgb8OutputTest,
                         ::testing::Values("out.png", "out.PNG", "out.ppm", "out.PpM"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           std::replace(name.begin(), name.end(), '.', '_');
                           return name;
                         });

TEST_F(CliTest, PfmOutputHasTheHeaderAndFloatPixels) {
  for (const std::string name : {"out.pfm", "OUT.PFM"}) {
    SCOPED_TRACE(name);
    const std::string bytes = RenderQuietly({"--width", "40", "--height", "30"}, name);
    const std::string header = "PF\n40 30\n-1.0\n";
    ASSERT_GE(bytes.size(), header.size());
    EXPECT_EQ(bytes.substr(0, header.size()), header);
    EXPECT_EQ(bytes.size(), header.size() + 40u * 30u * 3u * 4u);
    EXPECT_TRUE(fs::remove(work_ / name));
    ExpectOnlyFiles(work_, {});
  }
}

TEST_F(CliTest, OutputInASubfolderLeavesNoTemporaryFile) {
  fs::create_directory(work_ / "sub");
  const std::string bytes = RenderQuietly({"--width", "32", "--height", "32"}, "sub/x.png");
  ExpectOnlyFiles(work_, {"sub"});
  ExpectOnlyFiles(work_ / "sub", {"x.png"});
  ExpectRgb8Image(work_ / "sub" / "x.png", 32, 32);
}

TEST_F(CliTest, ExistingOutputFileIsReplaced) {
  std::ofstream(work_ / "x.png") << "not an image";
  RenderQuietly({"--width", "32", "--height", "24"}, "x.png");
  ExpectOnlyFiles(work_, {"x.png"});
  ExpectRgb8Image(work_ / "x.png", 32, 24);
}

TEST_F(CliTest, OneAndTwoThreadsGiveByteIdenticalPngs) {
  const RunResult one =
      Run({"render", "--width", "64", "--height", "64", "--threads", "1", "-o", "one.png"});
  EXPECT_EQ(one.exit_code, 0) << one.err;
  EXPECT_NE(one.out.find(", 1 thread) "), std::string::npos) << one.out;
  const RunResult two =
      Run({"render", "--width", "64", "--height", "64", "--threads", "2", "-o", "two.png"});
  EXPECT_EQ(two.exit_code, 0) << two.err;
  // The summary counts the threads that rendered a tile: this image's 16 tiles take well under a
  // millisecond, which may be over before the second thread starts.
  EXPECT_TRUE(two.out.find(", 2 threads) ") != std::string::npos ||
              two.out.find(", 1 thread) ") != std::string::npos)
      << two.out;
  const std::string a = ReadFile(work_ / "one.png");
  const std::string b = ReadFile(work_ / "two.png");
  EXPECT_FALSE(a.empty());
  EXPECT_TRUE(a == b) << "--threads 1 and --threads 2 wrote different files";
  ExpectOnlyFiles(work_, {"one.png", "two.png"});
}

TEST_F(CliTest, EveryKernelRenders) {
  for (const std::string kernel : {"inverse", "cramer", "moller-trumbore"}) {
    SCOPED_TRACE(kernel);
    const std::string name = kernel + ".png";
    RenderQuietly({"--width", "32", "--height", "32", "--kernel", kernel}, name);
    ExpectRgb8Image(work_ / name, 32, 32);
  }
  ExpectOnlyFiles(work_, {"cramer.png", "inverse.png", "moller-trumbore.png"});
}

// The two BVH builds make different trees with the same hits, so the same image; auto picks one.
TEST_F(CliTest, EveryBvhBuildWritesTheSameImage) {
  for (const std::string build : {"sah", "morton", "auto"}) {
    SCOPED_TRACE(build);
    RenderQuietly(
        {"--scene", "terrain:20000", "--width", "48", "--height", "32", "--bvh-build", build},
        build + ".png");
  }
  const std::string sah = ReadFile(work_ / "sah.png");
  EXPECT_FALSE(sah.empty());
  EXPECT_TRUE(sah == ReadFile(work_ / "morton.png"));
  EXPECT_TRUE(sah == ReadFile(work_ / "auto.png"));
  ExpectOnlyFiles(work_, {"auto.png", "morton.png", "sah.png"});
}

TEST_F(CliTest, FarLightChangesTheImage) {
  const std::string base = RenderQuietly({"--width", "64", "--height", "64"}, "default.png");
  const std::string far =
      RenderQuietly({"--width", "64", "--height", "64", "--light", "0,-100,-100"}, "far.png");
  EXPECT_FALSE(base.empty());
  EXPECT_FALSE(far.empty());
  EXPECT_TRUE(base != far) << "--light 0,-100,-100 gave the default image";
  ExpectRgb8Image(work_ / "far.png", 64, 64);
}

TEST_F(CliTest, YawChangesTheImage) {
  const std::string base = RenderQuietly({"--width", "64", "--height", "64"}, "default.png");
  const std::string turned =
      RenderQuietly({"--width", "64", "--height", "64", "--yaw", "0.5"}, "turned.png");
  EXPECT_FALSE(base.empty());
  EXPECT_TRUE(base != turned) << "--yaw 0.5 gave the default image";
}

TEST_F(CliTest, DistanceMovesTheLabCameraAlongItsView) {
  const std::string base = RenderQuietly({"--width", "64", "--height", "64"}, "default.png");
  const std::string three =
      RenderQuietly({"--width", "64", "--height", "64", "--distance", "3"}, "three.png");
  const std::string closer =
      RenderQuietly({"--width", "64", "--height", "64", "--distance", "2"}, "closer.png");
  EXPECT_FALSE(base.empty());
  EXPECT_EQ(base, three) << "--distance 3 is the lab's own distance";
  EXPECT_TRUE(base != closer) << "--distance 2 gave the default image";
}

TEST_F(CliTest, DistanceMovesAFileCameraTowardItsLookAt) {
  // scenes/cornell.json looks from (0, 0, -3) at the origin with the lab's 500 x 500 image and
  // focal length, so --distance 2 must give the built-in scene's --distance 2 image exactly:
  // (0, 0, -3) * 2 / 3 is (0, 0, -2).
  const std::string file = std::string(TRITRACE_SOURCE_DIR) + "/scenes/cornell.json";
  const std::string from_file = RenderQuietly({file, "--distance", "2"}, "file.png");
  const std::string built_in = RenderQuietly({"--distance", "2"}, "builtin.png");
  EXPECT_FALSE(from_file.empty());
  EXPECT_EQ(from_file, built_in);
}

TEST_F(CliTest, HelpListsEveryFlagAndExitsZero) {
  const RunResult r = Run({"render", "--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.err, "");
  for (const std::string flag :
       {"-o", "--output", "--width", "--height", "--kernel", "--bvh-build", "--yaw", "--distance",
        "--light", "--threads", "-q", "--quiet", "--help"}) {
    EXPECT_NE(r.out.find(flag), std::string::npos) << flag << " missing from:\n" << r.out;
  }
  for (const std::string kernel : {"inverse", "cramer", "moller-trumbore"}) {
    EXPECT_NE(r.out.find(kernel), std::string::npos) << kernel << " missing from:\n" << r.out;
  }
  ExpectOnlyFiles(work_, {});
}

// The lens and camera flags: one-line usage errors naming the flag, and info's camera list.
TEST_F(CliTest, LensAndCameraFlagsAreCheckedAndInfoListsGltfCameras) {
  const auto one_line_usage = [](const RunResult& r, const std::string& start) {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err.rfind(start, 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  };
  one_line_usage(Run({"render", "--aperture", "-1"}),
                 "tritrace: --aperture: must be a lens radius");
  one_line_usage(Run({"render", "--focus", "0"}), "tritrace: --focus: must be a finite number");
  one_line_usage(Run({"render", "--aperture", "0.1"}),
                 "tritrace: --aperture: applies to the path tracer");
  const std::string cameras = "/usr/share/assimp/models/glTF2/cameras/Cameras.gltf";
  if (!fs::exists(cameras)) GTEST_SKIP() << cameras << " not installed";
  one_line_usage(Run({"render", cameras, "--camera", "7", "--width", "8", "--height", "8"}),
                 "tritrace: --camera: no camera '7' in " + cameras + " (it has 0, 1)");
  const RunResult info = Run({"info", cameras});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("camera 0: perspective, yfov 0.7 rad"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("(rendered)"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("camera 1: orthographic, xmag 1, ymag 1"), std::string::npos) << info.out;
  const RunResult ortho = Run({"render", cameras, "--camera", "1", "--width", "16", "--height",
                               "16", "--spp", "1", "--aperture", "0.01", "-o", "o.png", "-q"});
  EXPECT_EQ(ortho.exit_code, 0) << ortho.err;
  EXPECT_TRUE(fs::exists(work_ / "o.png"));
}

TEST_F(CliTest, TopLevelHelpNamesTheRenderCommand) {
  const RunResult r = Run({"--help"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("render"), std::string::npos) << r.out;
  ExpectOnlyFiles(work_, {});
}

// ---- Errors ---------------------------------------------------------------------------------

TEST_F(CliTest, NoSubcommandIsAUsageError) {
  const RunResult r = Run({});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(CountLines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("tritrace: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("render"), std::string::npos) << r.err;
  ExpectOnlyFiles(work_, {});
}

TEST_F(CliTest, UnknownSubcommandIsAUsageError) {
  const RunResult r = Run({"draw"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(CountLines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("tritrace: ", 0), 0u) << r.err;
  ExpectOnlyFiles(work_, {});
}

struct ErrorCase {
  std::string name;               // test name suffix
  std::vector<std::string> args;  // after "render"
  int exit_code;
  std::string subject;  // what the message names first: the flag, argument or path
  std::string reason;   // a substring of the rest
};

std::ostream& operator<<(std::ostream& os, const ErrorCase& c) {
  os << "render";
  for (const std::string& a : c.args) os << " '" << a << "'";
  return os;
}

class CliErrorTest : public CliTest, public ::testing::WithParamInterface<ErrorCase> {};

TEST_P(CliErrorTest, PrintsOneLineAndWritesNoFile) {
  const ErrorCase& c = GetParam();
  std::vector<std::string> args = {"render"};
  args.insert(args.end(), c.args.begin(), c.args.end());
  const RunResult r = Run(args);
  ExpectErrorLine(r, c.exit_code, c.subject, c.reason);
  ExpectOnlyFiles(work_, {});
}

const char kSideRange[] = "must be an integer from 1 to 16384";
const char kThreadRange[] = "must be an integer from 1 to 1024";
const char kVec3[] = "must be three finite numbers X,Y,Z";
const char kFinite[] = "must be a finite number";
const char kDistance[] = "must be a finite number greater than 0";
const char kExtension[] = "unknown extension (use .png, .ppm, .pfm or .exr)";
const char kNeedsExr[] = "needs an .exr output";

INSTANTIATE_TEST_SUITE_P(
    Errors, CliErrorTest,
    ::testing::Values(
        ErrorCase{"UnknownFlag", {"--bogus"}, 2, "--bogus", "unknown option"},
        ErrorCase{"SecondPositional", {"a.obj", "extra"}, 2, "extra", "unknown option or argument"},
        ErrorCase{"WidthMissingValue", {"--width"}, 2, "--width", "missing value"},
        ErrorCase{"OutputMissingValue", {"-o"}, 2, "--output", "missing value"},
        ErrorCase{"WidthZero", {"--width", "0"}, 2, "--width", kSideRange},
        ErrorCase{"WidthZeroWithEquals", {"--width=0"}, 2, "--width", kSideRange},
        ErrorCase{"WidthNegative", {"--width", "-5"}, 2, "--width", kSideRange},
        ErrorCase{"WidthNotANumber", {"--width", "abc"}, 2, "--width", kSideRange},
        ErrorCase{"WidthFractional", {"--width", "1.5"}, 2, "--width", kSideRange},
        ErrorCase{"WidthWithPlusSign", {"--width", "+5"}, 2, "--width", kSideRange},
        ErrorCase{"WidthWithLeadingSpace", {"--width", " 5"}, 2, "--width", kSideRange},
        ErrorCase{"WidthWithTrailingJunk", {"--width", "5px"}, 2, "--width", kSideRange},
        ErrorCase{"WidthEmpty", {"--width", ""}, 2, "--width", kSideRange},
        ErrorCase{"WidthAboveMaximum", {"--width", "16385"}, 2, "--width", kSideRange},
        ErrorCase{"WidthHuge", {"--width", "99999999999999999999"}, 2, "--width", kSideRange},
        ErrorCase{"HeightZero", {"--height", "0"}, 2, "--height", kSideRange},
        ErrorCase{"HeightNegative", {"--height", "-1"}, 2, "--height", kSideRange},
        ErrorCase{"HeightAboveMaximum", {"--height", "16385"}, 2, "--height", kSideRange},
        ErrorCase{"ThreadsZero", {"--threads", "0"}, 2, "--threads", kThreadRange},
        ErrorCase{"ThreadsAboveMaximum", {"--threads", "1025"}, 2, "--threads", kThreadRange},
        ErrorCase{"ThreadsNotANumber", {"--threads", "many"}, 2, "--threads", kThreadRange},
        ErrorCase{"UnknownKernel", {"--kernel", "foo"}, 2, "--kernel", "unknown kernel 'foo'"},
        ErrorCase{"KernelMissingValue", {"--kernel"}, 2, "--kernel", "missing value"},
        ErrorCase{"UnknownBvhBuild",
                  {"--bvh-build", "lbvh"},
                  2,
                  "--bvh-build",
                  "unknown BVH build 'lbvh' (use auto, sah or morton)"},
        ErrorCase{"UnknownScene", {"--scene", "teapot"}, 2, "--scene", "unknown scene 'teapot'"},
        ErrorCase{"TerrainWithoutCount", {"--scene", "terrain:"}, 2, "--scene", "unknown scene"},
        ErrorCase{"UnknownAccel", {"--accel", "kdtree"}, 2, "--accel", "unknown acceleration"},
        ErrorCase{"LightTwoNumbers", {"--light", "1,2"}, 2, "--light", kVec3},
        ErrorCase{"LightNaN", {"--light", "1,nan,2"}, 2, "--light", kVec3},
        ErrorCase{"LightFourNumbers", {"--light", "1,2,3,4"}, 2, "--light", kVec3},
        ErrorCase{"LightInfinite", {"--light", "inf,0,0"}, 2, "--light", kVec3},
        ErrorCase{"LightBeyondFloat", {"--light", "1e39,0,0"}, 2, "--light", kVec3},
        ErrorCase{"LightEmptyPart", {"--light", "1,,2"}, 2, "--light", kVec3},
        ErrorCase{"DistanceZero", {"--distance", "0"}, 2, "--distance", kDistance},
        ErrorCase{"DistanceNegative", {"--distance", "-1"}, 2, "--distance", kDistance},
        ErrorCase{"DistanceBelowFloat", {"--distance", "1e-50"}, 2, "--distance", kDistance},
        ErrorCase{"DistanceBeyondFloat", {"--distance", "1e39"}, 2, "--distance", kDistance},
        ErrorCase{"DistanceNaN", {"--distance", "nan"}, 2, "--distance", kDistance},
        ErrorCase{"DistanceNotANumber", {"--distance", "far"}, 2, "--distance", kDistance},
        ErrorCase{"YawInfinite", {"--yaw", "inf"}, 2, "--yaw", kFinite},
        ErrorCase{"YawNaN", {"--yaw", "nan"}, 2, "--yaw", kFinite},
        ErrorCase{"YawNotANumber", {"--yaw", "abc"}, 2, "--yaw", kFinite},
        ErrorCase{"UnknownOutputExtension", {"-o", "x.jpg"}, 2, "--output", kExtension},
        ErrorCase{"OutputWithoutExtension", {"--output", "image"}, 2, "--output", kExtension},
        // Any reason: an empty path has no extension and is no file name either.
        ErrorCase{"EmptyOutputPath", {"-o", ""}, 2, "--output", ""},
        // A bad value is reported even when a valid render would otherwise follow.
        ErrorCase{"BadValueAmongGoodOnes",
                  {"--width", "64", "--height", "64", "--yaw", "inf", "-o", "x.png"},
                  2,
                  "--yaw",
                  kFinite},
        // A bad extension is reported before the folder is looked at.
        ErrorCase{"BadExtensionInMissingFolder", {"-o", "nodir/x.jpg"}, 2, "--output", kExtension},
        ErrorCase{"AovsUnknownName",
                  {"--aovs", "albedo,colour", "-o", "x.exr"},
                  2,
                  "--aovs",
                  "unknown AOV 'colour' in 'albedo,colour' (use a comma-separated list of albedo, "
                  "normal, depth, variance, spp)"},
        ErrorCase{"AovsEmptyName",
                  {"--aovs", "albedo,,depth", "-o", "x.exr"},
                  2,
                  "--aovs",
                  "empty AOV name"},
        ErrorCase{"AovsEmpty", {"--aovs", "", "-o", "x.exr"}, 2, "--aovs", "empty AOV name"},
        ErrorCase{"AovsUpperCase",
                  {"--aovs", "Albedo", "-o", "x.exr"},
                  2,
                  "--aovs",
                  "unknown AOV 'Albedo'"},
        ErrorCase{"AovsMissingValue", {"-o", "x.exr", "--aovs"}, 2, "--aovs", "missing value"},
        ErrorCase{"AovsWithPng", {"--aovs", "albedo", "-o", "x.png"}, 2, "--aovs", kNeedsExr},
        ErrorCase{"AovsWithPfm", {"--aovs", "depth", "-o", "x.pfm"}, 2, "--aovs", kNeedsExr},
        // Without -o the built-in scene writes cornell.png.
        ErrorCase{"AovsWithTheDefaultOutput",
                  {"--aovs", "normal"},
                  2,
                  "--aovs",
                  "needs an .exr output, got 'cornell.png'"},
        ErrorCase{"ExrHalfWithPfm", {"--exr-half", "-o", "x.pfm"}, 2, "--exr-half", kNeedsExr},
        ErrorCase{"ExposureOnTheLabIntegrator",
                  {"--exposure", "1", "-o", "x.png"},
                  2,
                  "--exposure",
                  "applies to path images; the lab integrator keeps the lab's clamp without "
                  "gamma"},
        ErrorCase{
            "ExposureOnTheLabIntegratorOfCornellArea",
            {"--scene", "cornell-area", "--integrator", "lab", "--exposure", "0", "-o", "x.ppm"},
            2,
            "--exposure",
            "applies to path images"},
        ErrorCase{"ExposureWithExr",
                  {"--scene", "cornell-area", "--exposure", "1", "-o", "x.exr"},
                  2,
                  "--exposure",
                  "applies to 8-bit outputs (.png, .ppm)"},
        ErrorCase{"ExposureWithPfm",
                  {"--scene", "cornell-area", "--exposure", "1", "-o", "x.pfm"},
                  2,
                  "--exposure",
                  "applies to 8-bit outputs"},
        ErrorCase{"ExposureInfinite", {"--exposure", "inf"}, 2, "--exposure", kFinite},
        ErrorCase{"ExposureNaN", {"--exposure", "nan"}, 2, "--exposure", kFinite},
        ErrorCase{"ExposureBeyondFloat", {"--exposure", "1e39"}, 2, "--exposure", kFinite},
        ErrorCase{"ExposureNotANumber", {"--exposure", "bright"}, 2, "--exposure", kFinite},
        // A glTF sun (a directional light) is for path and bdpt.
        ErrorCase{"LabRefusesADirectionalLight",
                  {std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/plane_sun.gltf",
                   "--integrator", "lab"},
                  2,
                  "--integrator",
                  "shades point lights only"},
        // Runtime errors.
        ErrorCase{
            "OutputFolderMissing", {"-o", "nodir/x.png"}, 1, "nodir/x.png", "does not exist"}),
    [](const ::testing::TestParamInfo<ErrorCase>& info) { return info.param.name; });

TEST_F(CliTest, OutputPathThatIsAFolderIsARuntimeError) {
  fs::create_directory(work_ / "out.png");
  const RunResult r = Run({"render", "--width", "16", "--height", "16", "-o", "out.png"});
  ExpectErrorLine(r, 1, "out.png", "folder");
  ExpectOnlyFiles(work_, {"out.png"});
  EXPECT_TRUE(fs::is_directory(work_ / "out.png"));
  ExpectOnlyFiles(work_ / "out.png", {});
}

TEST_F(CliTest, OutputFolderThatIsAFileIsARuntimeError) {
  std::ofstream(work_ / "plain.txt") << "text";
  const RunResult r = Run({"render", "--width", "16", "--height", "16", "-o", "plain.txt/x.png"});
  ExpectErrorLine(r, 1, "plain.txt/x.png", "not a folder");
  ExpectOnlyFiles(work_, {"plain.txt"});
  EXPECT_EQ(ReadFile(work_ / "plain.txt"), "text");
}

TEST_F(CliTest, UnwritableOutputFolderIsARuntimeError) {
  if (::geteuid() == 0) {
    GTEST_SKIP() << "running as root, where permission bits do not stop writes";
  }
  const fs::path locked = work_ / "locked";
  fs::create_directory(locked);
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  const RunResult r = Run({"render", "--width", "16", "--height", "16", "-o", "locked/x.png"});
  ExpectErrorLine(r, 1, "locked/x.png", "not writable");
  ExpectOnlyFiles(work_, {"locked"});
  ExpectOnlyFiles(locked, {});
}

// Root ignores permission bits, but /proc refuses new files from anyone: the write itself fails,
// after the render, and must still leave nothing behind and exit 1.
TEST_F(CliTest, FolderThatRefusesNewFilesIsARuntimeError) {
  const RunResult r = Run({"render", "--width", "16", "--height", "16", "-o", "/proc/x.png"});
  ExpectErrorLine(r, 1, "/proc/x.png", "cannot create");
  EXPECT_FALSE(fs::exists("/proc/x.png"));
  ExpectOnlyFiles(work_, {});
}

// tritrace bench: the records a script reads, for every scene and accel asked for.
TEST_F(CliTest, BenchWritesATableAndJsonRecords) {
  const RunResult r = Run({"bench", "--scene", "cornell", "--scene", "terrain:2k", "--width", "64",
                           "--height", "36", "--reps", "2", "--json", "b.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.find("cornell"), std::string::npos);
  EXPECT_NE(r.out.find("terrain:2k"), std::string::npos);
  EXPECT_NE(r.out.find("peak RSS"), std::string::npos);
  // The lab's table keeps its columns (path adds spp and Mpaths/s).
  EXPECT_EQ(r.out.substr(0, r.out.find('\n')),
            "scene          triangles accel         kernel            build ms    B/tri   +tri B  "
            "frame ms median (min-max)   Mrays/s  /embree  /robust");
  ExpectOnlyFiles(work_, {"b.json"});
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "b.json"));
  ASSERT_TRUE(records.is_array());
  std::set<std::string> accels;
  for (const nlohmann::json& rec : records) {
    for (const char* key :
         {"scene", "triangles", "accel", "kernel", "robust", "build_ms", "bytes_per_tri",
          "frame_ms_median", "frame_ms_min", "frame_ms_max", "mrays_per_s", "ratio_to_embree",
          "ratio_to_embree_robust", "threads", "width", "height"}) {
      EXPECT_TRUE(rec.contains(key)) << key;
    }
    const std::string accel = rec["accel"].get<std::string>();
    accels.insert(accel);
    EXPECT_EQ(rec["width"], 64);
    EXPECT_EQ(rec["height"], 36);
    EXPECT_EQ(rec["integrator"], "lab");
    EXPECT_EQ(rec["spp"], 1);
    EXPECT_GT(rec["mrays_per_s"].get<double>(), 0.0);
    EXPECT_LE(rec["frame_ms_min"].get<double>(), rec["frame_ms_median"].get<double>());
    EXPECT_LE(rec["frame_ms_median"].get<double>(), rec["frame_ms_max"].get<double>());
    // cornell is the lab's 30 triangles; terrain:2k is a 32 x 32 grid of quads plus the room.
    EXPECT_EQ(rec["triangles"], rec["scene"] == "cornell" ? 30 : 2 * 32 * 32 + 10);
    // Without --kernel each accel runs with the kernel `tritrace render` gives it; Embree with
    // its own.
    const std::string kernel = accel.starts_with("embree")
                                   ? "embree"
                                   : std::string(tritrace::kernel_name(tritrace::default_kernel_for(
                                         *tritrace::parse_accel(accel))));
    EXPECT_EQ(rec["kernel"], kernel) << accel;
    EXPECT_EQ(rec["robust"], accel == "embree-robust") << accel;
  }
  EXPECT_TRUE(accels.count("bvh"));
  EXPECT_TRUE(accels.count("brute"));
#if TRITRACE_HAVE_EMBREE
  EXPECT_TRUE(accels.count("embree"));
  EXPECT_TRUE(accels.count("embree-single"));
  EXPECT_TRUE(accels.count("embree-robust"));
  // The fastest non-robust Embree mode of each scene is the reference of ratio_to_embree, so one
  // of them has ratio 1; embree-robust is the reference of ratio_to_embree_robust.
  for (const std::string scene : {"cornell", "terrain:2k"}) {
    double best = 0.0;
    for (const nlohmann::json& rec : records) {
      if (rec["scene"] != scene) continue;
      const std::string accel = rec["accel"].get<std::string>();
      if (accel.starts_with("embree") && accel != "embree-robust") {
        best = std::max(best, rec["ratio_to_embree"].get<double>());
      }
      if (accel == "embree-robust") {
        EXPECT_DOUBLE_EQ(rec["ratio_to_embree_robust"].get<double>(), 1.0) << scene;
      }
    }
    EXPECT_DOUBLE_EQ(best, 1.0) << scene;
  }
#else
  for (const nlohmann::json& rec : records) {
    EXPECT_TRUE(rec["ratio_to_embree"].is_null());
    EXPECT_TRUE(rec["ratio_to_embree_robust"].is_null());
  }
#endif
}

// --kernel repeated: the accels that take a kernel get one row per kernel, in the order asked,
// so one session times the BVH with both side by side; Embree keeps one row (its own kernel).
TEST_F(CliTest, BenchRepeatedKernelGivesARowPerKernel) {
  std::vector<std::string> args = {"bench", "--scene", "cornell", "--width", "32",    "--height",
                                   "18",    "--reps",  "1",       "--json",  "k.json"};
  args.insert(args.end(), {"--accel", "bvh", "--accel", "brute"});
  args.insert(args.end(), {"--kernel", "watertight", "--kernel", "moller-trumbore"});
#if TRITRACE_HAVE_EMBREE
  args.insert(args.end(), {"--accel", "embree-robust"});
#endif
  const RunResult r = Run(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "k.json"));
  std::vector<std::pair<std::string, std::string>> rows;
  for (const nlohmann::json& rec : records) {
    rows.emplace_back(rec["accel"].get<std::string>(), rec["kernel"].get<std::string>());
  }
  std::vector<std::pair<std::string, std::string>> want = {{"bvh", "watertight"},
                                                           {"bvh", "moller-trumbore"},
                                                           {"brute", "watertight"},
                                                           {"brute", "moller-trumbore"}};
#if TRITRACE_HAVE_EMBREE
  want.emplace_back("embree-robust", "embree");
#endif
  EXPECT_EQ(rows, want);
  // The table names the kernel of each row.
  std::istringstream table(r.out);
  std::string line;
  int bvh_rows = 0;
  while (std::getline(table, line)) {
    if (line.starts_with("cornell") && line.find(" bvh ") != std::string::npos) {
      ++bvh_rows;
      EXPECT_TRUE(line.find("watertight") != std::string::npos ||
                  line.find("moller-trumbore") != std::string::npos)
          << line;
    }
  }
  EXPECT_EQ(bvh_rows, 2) << r.out;
}

// tritrace bench --integrator path: the path tracer's workload (cornell-area by default), with
// paths per second beside rays per second for every accel, in the table and the records.
// --bvh-build gives bvh a row per build, named in the table and the records; other accels one.
TEST_F(CliTest, BenchRepeatedBvhBuildGivesARowPerBuild) {
  const RunResult r = Run({"bench", "--scene", "cornell", "--width", "32", "--height", "18",
                           "--reps", "1", "--json", "b.json", "--accel", "bvh", "--accel", "brute",
                           "--bvh-build", "sah", "--bvh-build", "morton"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "b.json"));
  std::vector<std::pair<std::string, std::string>> rows;
  for (const nlohmann::json& rec : records) {
    rows.emplace_back(rec["accel"].get<std::string>(), rec["bvh_build"].get<std::string>());
  }
  const std::vector<std::pair<std::string, std::string>> want = {
      {"bvh", "sah"}, {"bvh/morton", "morton"}, {"brute", ""}};
  EXPECT_EQ(rows, want);
  EXPECT_NE(r.out.find("bvh/morton"), std::string::npos) << r.out;
  const RunResult bad = Run({"bench", "--bvh-build", "auto"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--bvh-build"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("unknown BVH build 'auto' (use sah or morton)"), std::string::npos)
      << bad.err;
}

// --denoise: each path frame is rendered with the denoiser's AOVs and denoised, and the
// denoiser's median time is a column and a record field; without it the field is null.
TEST_F(CliTest, BenchDenoiseTimesTheDenoiserOnEachPathFrame) {
  const RunResult r =
      Run({"bench", "--integrator", "path", "--width", "32", "--height", "24", "--spp", "2",
           "--reps", "2", "--accel", "bvh", "--denoise", "--json", "d.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.substr(0, r.out.find('\n')).find("denoise ms"), std::string::npos) << r.out;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "d.json"));
  ASSERT_EQ(records.size(), 1u);
  ASSERT_TRUE(records[0]["denoise_ms_median"].is_number()) << records[0];
  EXPECT_GT(records[0]["denoise_ms_median"].get<double>(), 0.0);
  const RunResult plain = Run({"bench", "--integrator", "path", "--width", "16", "--height", "16",
                               "--spp", "1", "--reps", "1", "--accel", "bvh", "--json", "e.json"});
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(plain.out.find("denoise"), std::string::npos) << plain.out;
  EXPECT_TRUE(nlohmann::json::parse(ReadFile(work_ / "e.json"))[0]["denoise_ms_median"].is_null());
  const RunResult lab = Run({"bench", "--denoise"});
  EXPECT_EQ(lab.exit_code, 2);
  EXPECT_NE(lab.err.find("--denoise"), std::string::npos) << lab.err;
}

TEST_F(CliTest, BenchTimesTheBidirectionalPathTracer) {
  const RunResult r = Run({"bench", "--integrator", "bdpt", "--width", "16", "--height", "16",
                           "--spp", "2", "--reps", "1", "--accel", "bvh", "--json", "b.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("integrator bdpt, 2 spp"), std::string::npos) << r.out;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "b.json"));
  ASSERT_TRUE(records.is_array());
  ASSERT_FALSE(records.empty());
  for (const nlohmann::json& rec : records) {
    EXPECT_EQ(rec["scene"], "cornell-area");
    EXPECT_EQ(rec["integrator"], "bdpt");
  }
}

// --light-paths reaches bench's bdpt frames as it reaches render's: a share given is the one
// rendered, auto runs the pilot (its line names its choice, one of the five it chooses among), and
// it is a usage error for the other integrators or out of range.
TEST_F(CliTest, BenchTakesBdptsShareOfLightPaths) {
  const RunResult given =
      Run({"bench", "--integrator", "bdpt", "--width", "16", "--height", "16", "--spp", "2",
           "--reps", "1", "--accel", "bvh", "--light-paths", "0.25", "--json", "q.json"});
  ASSERT_EQ(given.exit_code, 0) << given.err;
  const nlohmann::json quarter = nlohmann::json::parse(ReadFile(work_ / "q.json"));
  ASSERT_EQ(quarter.size(), 1u);
  EXPECT_DOUBLE_EQ(quarter[0]["light_paths"].get<double>(), 0.25);

  const RunResult automatic =
      Run({"bench", "--integrator", "bdpt", "--width", "16", "--height", "16", "--spp", "2",
           "--reps", "1", "--accel", "bvh", "--light-paths", "auto", "--json", "a.json"});
  ASSERT_EQ(automatic.exit_code, 0) << automatic.err;
  EXPECT_NE(automatic.out.find("cornell-area: bdpt --light-paths auto chose"), std::string::npos)
      << automatic.out;
  const nlohmann::json chosen = nlohmann::json::parse(ReadFile(work_ / "a.json"));
  ASSERT_EQ(chosen.size(), 1u);
  const double f = chosen[0]["light_paths"].get<double>();
  // One of the pilot's shares: 1, 1/2, ..., 1/64.
  bool share = false;
  for (int k = 0; k <= 6; ++k) share = share || f == std::ldexp(1.0, -k);
  EXPECT_TRUE(share) << f;

  ExpectErrorLine(Run({"bench", "--integrator", "path", "--light-paths", "0.5"}), 2,
                  "--light-paths", "applies to bdpt");
  ExpectErrorLine(Run({"bench", "--integrator", "bdpt", "--light-paths", "2"}), 2, "--light-paths",
                  "at most 1, got '2'");
}

// --secondary-rays: one frame's bounce and shadow rays recorded through bvh and traced again. The
// counts come from the camera (pixels x spp camera rays, the rest recorded) and the recording
// accel's replay must give its own answers back bit for bit.
TEST_F(CliTest, BenchSecondaryRaysReplaysTheFramesRays) {
  const RunResult r =
      Run({"bench", "--integrator", "path", "--secondary-rays", "--width", "16", "--height", "16",
           "--spp", "2", "--reps", "1", "--threads", "2", "--json", "s.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_NE(r.out.substr(0, r.out.find('\n')).find("closest"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("recorded through bvh: 512 camera (coherent)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("NOT the frame's count"), std::string::npos) << r.out;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "s.json"));
  ASSERT_TRUE(records.is_array());
#if TRITRACE_HAVE_EMBREE
  ASSERT_EQ(records.size(), 2u);  // bvh and embree-single by default
  EXPECT_EQ(records[1]["accel"], "embree-single");
  EXPECT_DOUBLE_EQ(records[1]["closest_ratio_to_embree_single"].get<double>(), 1.0);
  EXPECT_EQ(records[1]["closest_rays"], records[0]["closest_rays"]);
  // Embree's own rounding may send a ray at an edge elsewhere, rarely.
  EXPECT_LE(records[1]["closest_hit_or_miss_disagreements"].get<double>(),
            0.01 * records[1]["closest_rays"].get<double>());
#else
  ASSERT_EQ(records.size(), 1u);
#endif
  const nlohmann::json& bvh = records[0];
  EXPECT_EQ(bvh["accel"], "bvh");
  EXPECT_EQ(bvh["recorded_with"], true);
  EXPECT_EQ(bvh["spp"], 2);
  EXPECT_EQ(bvh["threads"], 2);
  EXPECT_GT(bvh["closest_rays"].get<int>(), 0);
  EXPECT_GT(bvh["any_rays"].get<int>(), 0);
  EXPECT_GT(bvh["closest_mrays_per_s"].get<double>(), 0.0);
  EXPECT_EQ(bvh["closest_not_identical"], 0);
  EXPECT_EQ(bvh["closest_hit_or_miss_disagreements"], 0);
  EXPECT_EQ(bvh["any_disagreements"], 0);

  ExpectErrorLine(Run({"bench", "--secondary-rays"}), 2, "--secondary-rays",
                  "use --integrator path or bdpt");
  ExpectErrorLine(
      Run({"bench", "--integrator", "path", "--secondary-rays", "--kernel", "moller-trumbore"}), 2,
      "--secondary-rays", "do not apply");
}

// The example scene with a spot light and a sun, and a glTF sun, render with bdpt (its light
// subpaths start on them), through a lens too.
TEST_F(CliTest, BdptRendersSpotAndDirectionalLightsThroughALens) {
  for (const std::string& scene :
       {std::string(TRITRACE_SOURCE_DIR) + "/scenes/spot_and_sun.json",
        std::string(TRITRACE_SOURCE_DIR) + "/tests/data/gltf/plane_sun.gltf"}) {
    const RunResult r = Run({"render", scene, "--integrator", "bdpt", "--width", "16", "--height",
                             "16", "--spp", "2", "--aperture", "0.05", "-o", "s.png", "-q"});
    EXPECT_EQ(r.exit_code, 0) << scene << ": " << r.err;
    EXPECT_TRUE(std::filesystem::exists(work_ / "s.png")) << scene;
  }
}

TEST_F(CliTest, BenchWithThePathTracerReportsPathsPerSecond) {
  const RunResult r = Run({"bench", "--integrator", "path", "--width", "32", "--height", "24",
                           "--spp", "2", "--reps", "2", "--json", "p.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  std::istringstream table(r.out);
  std::string header;
  std::getline(table, header);
  EXPECT_NE(header.find(" spp "), std::string::npos) << header;
  EXPECT_NE(header.find("Mpaths/s"), std::string::npos) << header;
  EXPECT_NE(r.out.find("integrator path, 2 spp"), std::string::npos) << r.out;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "p.json"));
  ASSERT_TRUE(records.is_array());
  std::set<std::string> accels;
  for (const nlohmann::json& rec : records) {
    accels.insert(rec["accel"].get<std::string>());
    EXPECT_EQ(rec["scene"], "cornell-area");
    EXPECT_EQ(rec["triangles"], 32);  // the lab's 30 and the ceiling light's two
    EXPECT_EQ(rec["integrator"], "path");
    EXPECT_EQ(rec["spp"], 2);
    // Paths per frame are pixels x spp, whatever the accel: the rate is that over the median.
    const double frame_ms = rec["frame_ms_median"].get<double>();
    EXPECT_NEAR(rec["mpaths_per_s"].get<double>(), 32.0 * 24.0 * 2.0 / (frame_ms * 1e3),
                1e-9 * rec["mpaths_per_s"].get<double>());
    // Nearly every camera ray here sees a wall, floor or block (the box fills the view; only the
    // small light ends a path at once), and each of those adds at least a bounce ray.
    EXPECT_GT(rec["mrays_per_s"].get<double>(), 1.5 * rec["mpaths_per_s"].get<double>());
  }
  EXPECT_TRUE(accels.count("bvh"));
  EXPECT_TRUE(accels.count("brute"));
#if TRITRACE_HAVE_EMBREE
  EXPECT_TRUE(accels.count("embree-single"));
  // Ratios are of paths per second here: the fastest non-robust Embree mode's is 1.
  double best = 0.0;
  for (const nlohmann::json& rec : records) {
    const std::string accel = rec["accel"].get<std::string>();
    if (accel.starts_with("embree") && accel != "embree-robust") {
      best = std::max(best, rec["ratio_to_embree"].get<double>());
    }
  }
  EXPECT_DOUBLE_EQ(best, 1.0);
#endif
}

TEST_F(CliTest, BenchRejectsAnUnknownIntegrator) {
  const RunResult r = Run({"bench", "--integrator", "whitted"});
  ExpectErrorLine(r, 2, "--integrator", "unknown integrator 'whitted'");
  ExpectOnlyFiles(work_, {});
}

TEST_F(CliTest, BenchRejectsAnUnknownKernel) {
  const RunResult r = Run({"bench", "--kernel", "watertight", "--kernel", "fast"});
  ExpectErrorLine(r, 2, "--kernel", "unknown kernel 'fast'");
  ExpectOnlyFiles(work_, {});
}

// embree-robust is an accel like the others: where Embree is built in it renders the scene as brute
// force does but for pixels on geometric and shadow edges, where Embree's rounding of t, u and v
// differs from our kernel's (92 of 4096 pixels here); where it is not built in, the flag is
// refused.
TEST_F(CliTest, EmbreeRobustAccelRendersTheScene) {
#if TRITRACE_HAVE_EMBREE
  const std::vector<std::string> size = {"--width", "64", "--height", "64"};
  std::vector<std::string> robust = size, brute = size;
  robust.insert(robust.end(), {"--accel", "embree-robust"});
  brute.insert(brute.end(), {"--accel", "brute"});
  RenderQuietly(robust, "robust.png");
  RenderQuietly(brute, "brute.png");
  const tritrace::Rgb8Image a = tritrace::read_image_rgb8((work_ / "robust.png").string());
  const tritrace::Rgb8Image b = tritrace::read_image_rgb8((work_ / "brute.png").string());
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  ASSERT_EQ(a.rgb.size(), 64u * 64u * 3u);
  size_t differing = 0;
  for (size_t i = 0; i < a.rgb.size(); i += 3) {
    differing += !std::equal(a.rgb.begin() + i, a.rgb.begin() + i + 3, b.rgb.begin() + i);
  }
  EXPECT_LT(differing, 64u * 64u / 20) << "pixels differing from brute force";
#else
  const RunResult r = Run({"render", "--accel", "embree-robust"});
  ExpectErrorLine(r, 2, "--accel", "not built in");
#endif
}

TEST_F(CliTest, BenchSkipsBruteForceWhereAFrameWouldTakeSeconds) {
  const RunResult r = Run({"bench", "--scene", "terrain:1m", "--accel", "brute", "--width", "64",
                           "--height", "36", "--reps", "1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("skipped"), std::string::npos) << r.out;
}

// The project's version as CMakeLists.txt's project() line gives it.
std::string ProjectVersion() {
  const std::string cmake = ReadFile(fs::path(TRITRACE_SOURCE_DIR) / "CMakeLists.txt");
  std::smatch m;
  EXPECT_TRUE(std::regex_search(cmake, m, std::regex(R"(project\(tritrace VERSION ([0-9.]+))")));
  return m.size() > 1 ? m[1].str() : "";
}

TEST_F(CliTest, VersionNamesTheBuildAndExitsZero) {
  const RunResult r = Run({"--version"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      r.out, m, std::regex(R"(^tritrace ([0-9.]+) \(commit ([0-9a-f]+|unknown)(-dirty)?\)\n)")))
      << r.out;
  EXPECT_EQ(m[1].str(), ProjectVersion());
  // The commit is one of this repository's (where git and the repository are at hand).
  const std::string commit = m[2].str();
  if (commit != "unknown" && fs::exists(fs::path(TRITRACE_SOURCE_DIR) / ".git")) {
    const std::string check = "git -C '" + std::string(TRITRACE_SOURCE_DIR) + "' cat-file -e " +
                              commit + "^{commit} 2>/dev/null";
    EXPECT_EQ(std::system(check.c_str()), 0) << commit << " is not a commit here";
  }
  for (const char* line : {"\ncompiler: ", "\nSIMD: ", "\nEmbree: ", "\nOpenEXR: ", "\nMPI: "}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line;
  }
#if TRITRACE_HAVE_EMBREE
  EXPECT_NE(r.out.find("\nEmbree: " RTC_VERSION_STRING "\n"), std::string::npos) << r.out;
#else
  EXPECT_NE(r.out.find("\nEmbree: not built in\n"), std::string::npos) << r.out;
#endif
  EXPECT_NE(r.out.find("\nOpenEXR: " OPENEXR_VERSION_STRING "\n"), std::string::npos) << r.out;
}

TEST_F(CliTest, BenchTakesSceneAndMeshFilesAndRecordsTheBuild) {
  const std::string scene = std::string(TRITRACE_SOURCE_DIR) + "/scenes/cornell.json";
  const std::string mesh = "/usr/share/assimp/models/PLY/cube_binary.ply";
  const RunResult r = Run({"bench", scene, mesh, "--accel", "bvh", "--width", "32", "--height",
                           "24", "--reps", "1", "--json", "b.json", "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json records = nlohmann::json::parse(ReadFile(work_ / "b.json"));
  ASSERT_EQ(records.size(), 2u);  // the default scenes are not added when files are given
  EXPECT_EQ(records[0]["scene"], "cornell.json");
  EXPECT_EQ(records[0]["triangles"], 30);  // the lab box of the scene file
  EXPECT_EQ(records[1]["scene"], "cube_binary.ply");
  EXPECT_EQ(records[1]["triangles"], 12);  // its header's 12 faces
  const RunResult version = Run({"--version"});
  for (const nlohmann::json& rec : records) {
    for (const char* key : {"commit", "compiler", "cpu", "embree_version", "openexr_version",
                            "simd_lanes", "version", "mpi"}) {
      EXPECT_TRUE(rec.contains(key)) << key;
    }
    EXPECT_NE(version.out.find("(commit " + rec["commit"].get<std::string>() + ")"),
              std::string::npos);
    EXPECT_NE(version.out.find("compiler: " + rec["compiler"].get<std::string>() + "\n"),
              std::string::npos);
    EXPECT_FALSE(rec["cpu"].get<std::string>().empty());
  }
}

TEST_F(CliTest, BenchOfAMissingFileIsAnErrorNamingIt) {
  const RunResult r = Run({"bench", "no-such.ply", "--reps", "1"});
  ExpectErrorLine(r, 1, "no-such.ply", "");
}

TEST_F(CliTest, BenchRejectsAnUnknownScene) {
  const RunResult r = Run({"bench", "--scene", "teapot"});
  ExpectErrorLine(r, 2, "--scene", "unknown scene");
  ExpectOnlyFiles(work_, {});
}

// ---- Scene and mesh files --------------------------------------------------------------------

const std::string kModels = "/usr/share/assimp/models/";
const std::string kScenes = std::string(TRITRACE_SOURCE_DIR) + "/scenes/";

// How many of an 8-bit image's bytes are not zero: a lit render has many.
size_t NonZeroBytes(const fs::path& path) {
  const tritrace::Rgb8Image image = tritrace::read_image_rgb8(path.string());
  return image.rgb.size() - std::count(image.rgb.begin(), image.rgb.end(), 0);
}

TEST_F(CliTest, CornellJsonRendersByteIdenticalToTheBuiltInScene) {
  const std::string built_in = RenderQuietly({}, "built_in.png");
  const std::string from_json = RenderQuietly({kScenes + "cornell.json"}, "json.png");
  EXPECT_FALSE(built_in.empty());
  EXPECT_TRUE(built_in == from_json) << "scenes/cornell.json differs from the built-in scene";
}

TEST_F(CliTest, SceneFileOutputSettingNamesTheImage) {
  const RunResult r = Run({"render", kScenes + "cornell.json", "--width", "32", "--height", "32"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(" to cornell.png\n"), std::string::npos) << r.out;
  ExpectOnlyFiles(work_, {"cornell.png"});
  ExpectRgb8Image(work_ / "cornell.png", 32, 32);
}

TEST_F(CliTest, EveryExampleSceneRenders) {
  for (const fs::directory_entry& e : fs::directory_iterator(kScenes)) {
    if (e.path().extension() != ".json") continue;
    SCOPED_TRACE(e.path());
    RenderQuietly({e.path().string(), "--width", "48", "--height", "40"}, "x.png");
    ExpectRgb8Image(work_ / "x.png", 48, 40);
    EXPECT_GT(NonZeroBytes(work_ / "x.png"), 48u * 40u);
  }
}

// Real third-party models render at a small size with the default camera and light, and the image
// is neither black nor clipped to white everywhere.
TEST_F(CliTest, RealModelsRenderWithDefaults) {
  for (const std::string model :
       {"OBJ/spider.obj", "PLY/Wuson.ply", "STL/Spider_binary.stl",
        "glTF2/BoxTextured-glTF/BoxTextured.gltf", "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb",
        "Collada/duck.dae", "3DS/fels.3ds"}) {
    SCOPED_TRACE(model);
    if (!fs::exists(kModels + model)) {
      ADD_FAILURE() << "missing test model (install assimp-testmodels)";
      continue;
    }
    const RunResult r =
        Run({"render", kModels + model, "--width", "40", "--height", "40", "-o", "m.png", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const tritrace::Rgb8Image image = tritrace::read_image_rgb8((work_ / "m.png").string());
    const size_t zero = std::count(image.rgb.begin(), image.rgb.end(), 0);
    const size_t full = std::count(image.rgb.begin(), image.rgb.end(), 255);
    EXPECT_GT(image.rgb.size() - zero, 40u * 3u) << "almost black";
    EXPECT_LT(full, image.rgb.size() / 2) << "blown out";
  }
}

TEST_F(CliTest, MeshFileDefaultOutputIsItsNameAsPng) {
  const RunResult r = Run({"render", kModels + "PLY/cube.ply", "--width", "16", "--height", "16"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  ExpectOnlyFiles(work_, {"cube.png"});
}

TEST_F(CliTest, DroppedTrianglesGiveOneWarningLineAndStillRender) {
  // Two triangles, the second with a repeated vertex (zero area).
  std::ofstream(work_ / "two.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 2\n";
  const RunResult r = Run({"render", "two.obj", "--width", "16", "--height", "16"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "tritrace: two.obj: warning: dropped 1 degenerate and 0 non-finite triangles\n");
  ExpectOnlyFiles(work_, {"two.obj", "two.png"});
  const RunResult info = Run({"info", "two.obj"});
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("triangles: 1\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("dropped: 1 degenerate, 0 non-finite triangles\n"), std::string::npos)
      << info.out;
}

TEST_F(CliTest, InfoPrintsWhatWasLoaded) {
  const RunResult r = Run({"info", kScenes + "cornell.json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const std::string line :
       {"triangles: 30\n", "meshes: 7\n", "materials: 7\n", "bounds: (-1, -1, -1) to (1, 1, 1)\n",
        "lights: 1\n", "dropped: 0 degenerate, 0 non-finite triangles\n", "emissive triangles: 0\n",
        "integrator: lab\n"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line << " not in:\n" << r.out;
  }
  ExpectOnlyFiles(work_, {});
}

// scenes/instances.json: the 30-triangle box drawn once, the 4-triangle tetrahedron stored once
// and placed five times.
TEST_F(CliTest, InfoCountsInstancesAndTrianglesDrawnAndStored) {
  const RunResult r = Run({"info", kScenes + "instances.json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const std::string line :
       {"triangles: 50\n", "instances: 5 of 1 instanced meshes\n", "triangles stored: 34\n"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line << " not in:\n" << r.out;
  }
}

TEST_F(CliTest, EmbreeRefusesAnInstancedSceneInOneLine) {
  const RunResult r = Run({"render", kScenes + "instances.json", "--accel", "embree", "--width",
                           "8", "--height", "8", "-o", "x.png"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind("tritrace: --accel: ", 0), 0u) << r.err;
  ExpectOnlyFiles(work_, {});
}

TEST_F(CliTest, InfoCountsTheStlHeadersTriangles) {
  // The binary STL header's triangle count, read here independently of assimp.
  const std::string bytes = ReadFile(kModels + "STL/Spider_binary.stl");
  uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, 4);
  const RunResult r = Run({"info", kModels + "STL/Spider_binary.stl"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const std::regex kept(R"(triangles: ([0-9]+)\n)"),
      dropped(R"(dropped: ([0-9]+) degenerate, ([0-9]+) non-finite)");
  std::smatch k, d;
  ASSERT_TRUE(std::regex_search(r.out, k, kept)) << r.out;
  ASSERT_TRUE(std::regex_search(r.out, d, dropped)) << r.out;
  EXPECT_EQ(std::stoul(k[1]) + std::stoul(d[1]) + std::stoul(d[2]), count);
}

// Writes `text` to `name` in the work folder.
void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// ---- The path tracer ------------------------------------------------------------------------

TEST_F(CliTest, CornellAreaIsPathTracedAndTheSummaryGivesSpp) {
  const RunResult r = Run({"render", "--scene", "cornell-area", "--spp", "4", "--width", "32",
                           "--height", "24", "-o", "area.png"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("rendered 32x24, 4 spp in "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Mpaths/s"), std::string::npos) << r.out;
  ExpectRgb8Image(work_ / "area.png", 32, 24);
}

TEST_F(CliTest, PathImagesAreByteIdenticalForAnyThreadCountAndChangeWithTheSeed) {
  const std::vector<std::string> base = {"--scene", "cornell-area", "--spp",    "3",
                                         "--width", "40",           "--height", "40"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const std::string one = RenderQuietly(with({"--threads", "1"}), "one.pfm");
  const std::string two = RenderQuietly(with({"--threads", "2"}), "two.pfm");
  const std::string seeded = RenderQuietly(with({"--seed", "9"}), "seeded.pfm");
  EXPECT_FALSE(one.empty());
  EXPECT_TRUE(one == two);
  EXPECT_FALSE(one == seeded) << "--seed changes the random numbers";
}

TEST_F(CliTest, IntegratorFlagSwitchesTheLabBoxToPathTracing) {
  const std::string lab = RenderQuietly({"--width", "32", "--height", "32"}, "lab.pfm");
  const std::string path = RenderQuietly(
      {"--width", "32", "--height", "32", "--integrator", "path", "--spp", "2"}, "path.pfm");
  const std::string lab_again = RenderQuietly(
      {"--width", "32", "--height", "32", "--integrator", "lab", "--spp", "7"}, "lab7.pfm");
  EXPECT_FALSE(lab == path);
  EXPECT_TRUE(lab == lab_again) << "the lab integrator takes one sample whatever --spp says";
}

TEST_F(CliTest, BadPathFlagsNameTheFlagAndExitTwo) {
  ExpectErrorLine(Run({"render", "--integrator", "whitted"}), 2, "--integrator",
                  "unknown integrator 'whitted'");
  ExpectErrorLine(Run({"render", "--spp", "0"}), 2, "--spp", "");
  ExpectErrorLine(Run({"render", "--max-depth", "-1"}), 2, "--max-depth", "");
  ExpectErrorLine(Run({"render", "--seed", "x"}), 2, "--seed", "");
  ExpectErrorLine(Run({"render", "--filter", "mitchell"}), 2, "--filter", "unknown filter");
  ExpectErrorLine(Run({"render", "--sampler", "halton"}), 2, "--sampler",
                  "unknown sampler 'halton' (use sobol or independent)");
  ExpectOnlyFiles(work_, {});
}

// --sampler picks the numbers: sobol (the default) and independent give different images of the
// same scene, and a scene file's integrator.sampler is the same choice as the flag, bit for bit.
TEST_F(CliTest, SamplerFlagAndSceneKeyChooseTheNumbers) {
  const std::vector<std::string> base = {"--scene",  "cornell-area", "--width", "24",
                                         "--height", "24",           "--spp",   "4"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const std::string sobol = RenderQuietly(base, "default.pfm");
  const std::string named = RenderQuietly(with({"--sampler", "sobol"}), "sobol.pfm");
  const std::string independent =
      RenderQuietly(with({"--sampler", "independent"}), "independent.pfm");
  EXPECT_TRUE(sobol == named);
  EXPECT_FALSE(sobol == independent);

  const std::string scene = R"({
    "camera": {"width": 16, "height": 16},
    "meshes": [{"generator": "cornell-area"}],
    "integrator": {"type": "path", "spp": 2, "sampler": "independent"}
  })";
  WriteText(work_ / "box.json", scene);
  const std::string from_file = RenderQuietly({"box.json"}, "file.pfm");
  const std::string from_flag = RenderQuietly({"box.json", "--sampler", "independent"}, "flag.pfm");
  const std::string overridden = RenderQuietly({"box.json", "--sampler", "sobol"}, "over.pfm");
  EXPECT_TRUE(from_file == from_flag);
  EXPECT_FALSE(from_file == overridden);

  WriteText(work_ / "bad.json", R"({"meshes": [{"generator": "cornell"}],
                                     "integrator": {"sampler": "stratified"}})");
  ExpectErrorLine(Run({"render", "bad.json"}), 1, "bad.json",
                  "/integrator/sampler: must be \"sobol\" or \"independent\", got 'stratified'");
}

TEST_F(CliTest, SceneFileIntegratorObjectIsReadAndChecked) {
  const std::string scene = R"({
    "camera": {"width": 16, "height": 16},
    "materials": [{"name": "lamp", "albedo": [0, 0, 0], "emission": [2, 2, 2], "two_sided": true}],
    "meshes": [{"material": "lamp", "positions": [[-5, -5, 1], [5, -5, 1], [0, 5, 1]],
                "triangles": [[0, 1, 2]]}],
    "integrator": {"type": "path", "spp": 2, "max_depth": 0, "seed": 1}
  })";
  WriteText(work_ / "lamp.json", scene);
  const std::string pfm = RenderQuietly({"lamp.json"}, "lamp.pfm");
  // The camera sees the two-sided emitter straight ahead: the centre pixel is its radiance, 2.
  const size_t header = pfm.find("-1.0\n");
  ASSERT_NE(header, std::string::npos);
  float centre[3];
  std::memcpy(centre, pfm.data() + header + 5 + (8 * 16 + 8) * 3 * sizeof(float), sizeof centre);
  EXPECT_EQ(centre[0], 2.0f);
  EXPECT_EQ(centre[2], 2.0f);

  WriteText(work_ / "bad.json", R"({"meshes": [{"generator": "cornell"}],
                                     "integrator": {"type": "bidirectional"}})");
  ExpectErrorLine(Run({"render", "bad.json"}), 1, "bad.json", "/integrator/type");
  WriteText(work_ / "bad2.json", R"({"meshes": [{"generator": "cornell"}],
                                      "integrator": {"spp": 0}})");
  ExpectErrorLine(Run({"render", "bad2.json"}), 1, "bad2.json", "/integrator/spp");
}

struct FileErrorCase {
  std::string name;
  std::string file;                                        // the argument to render
  std::vector<std::pair<std::string, std::string>> files;  // written first: name, contents
  std::string subject;
  std::string reason;
};

std::ostream& operator<<(std::ostream& os, const FileErrorCase& c) {
  return os << c.file;
}

class CliFileErrorTest : public CliTest, public ::testing::WithParamInterface<FileErrorCase> {};

TEST_P(CliFileErrorTest, PrintsOneLineExitsOneAndWritesNoImage) {
  const FileErrorCase& c = GetParam();
  std::vector<std::string> before;
  for (const auto& [name, text] : c.files) {
    WriteText(work_ / name, text);
    before.push_back(name);
  }
  for (const std::string command : {"render", "info"}) {
    SCOPED_TRACE(command);
    const RunResult r = Run({command, c.file});
    ExpectErrorLine(r, 1, c.subject, c.reason);
    ExpectOnlyFiles(work_, before);
  }
}

const char kTriangle[] = R"({"positions": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]]})";

INSTANTIATE_TEST_SUITE_P(
    Files, CliFileErrorTest,
    ::testing::Values(
        FileErrorCase{"MissingFile", "nothing.obj", {}, "nothing.obj", "file not found"},
        FileErrorCase{"MissingScene", "nothing.json", {}, "nothing.json", "file not found"},
        FileErrorCase{"FolderInsteadOfFile", "/tmp", {}, "/tmp", "is a folder, not a file"},
        FileErrorCase{"DeviceInsteadOfFile", "/dev/zero", {}, "/dev/zero", "not a regular file"},
        FileErrorCase{"EmptyMesh", "e.obj", {{"e.obj", ""}}, "e.obj", "is empty"},
        FileErrorCase{"EmptyScene", "e.json", {{"e.json", ""}}, "e.json", "is empty"},
        FileErrorCase{"UnknownFormat",
                      "x.xyz",
                      {{"x.xyz", "hello\n"}},
                      "x.xyz",
                      "cannot import: No suitable reader"},
        FileErrorCase{"ObjWithOnlyLines",
                      "l.obj",
                      {{"l.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n"}},
                      "l.obj",
                      "contains no triangles"},
        FileErrorCase{"MalformedJson",
                      "s.json",
                      {{"s.json", "{\n  \"meshes\": [\n    ]]\n}"}},
                      "s.json",
                      "invalid JSON at line 3, column 6"},
        FileErrorCase{"UnknownKey",
                      "s.json",
                      {{"s.json", "{\"mesh\": []}"}},
                      "s.json",
                      "unknown key 'mesh' (did you mean 'meshes'?)"},
        FileErrorCase{"WrongType",
                      "s.json",
                      {{"s.json", "{\"meshes\": {}}"}},
                      "s.json",
                      "/meshes: must be an array, got an object"},
        FileErrorCase{"NaNLiteral",
                      "s.json",
                      {{"s.json", "{\"ambient\": [NaN, 0, 0]}"}},
                      "s.json",
                      "invalid JSON at line 1, column 14"},
        FileErrorCase{"InfiniteNumber",
                      "s.json",
                      {{"s.json", "{\"ambient\": [1e400, 0, 0]}"}},
                      "s.json",
                      "number 1e400 is out of range"},
        FileErrorCase{"BeyondFloat",
                      "s.json",
                      {{"s.json", std::string("{\"ambient\": [1e300, 0, 0], \"meshes\": [") +
                                      kTriangle + "]}"}},
                      "s.json",
                      "/ambient/0: is out of range for a 32-bit float"},
        FileErrorCase{"NegativeWidth",
                      "s.json",
                      {{"s.json", std::string("{\"camera\": {\"width\": -640}, \"meshes\": [") +
                                      kTriangle + "]}"}},
                      "s.json",
                      "/camera/width: must be an integer from 1 to 16384, got -640"},
        FileErrorCase{"IndexOutOfRange",
                      "s.json",
                      {{"s.json", R"({"meshes": [{"positions": [[0,0,0],[1,0,0],[0,1,0]],
                                       "triangles": [[0,1,7]]}]})"}},
                      "s.json",
                      "index 7 out of range (0 to 2)"},
        FileErrorCase{"ZeroTriangleMesh",
                      "s.json",
                      {{"s.json", R"({"meshes": [{"positions": [], "triangles": []}]})"}},
                      "s.json",
                      "mesh has no triangles"},
        FileErrorCase{
            "NoGeometry", "s.json", {{"s.json", "{\"meshes\": []}"}}, "s.json", "no geometry"},
        FileErrorCase{"MissingReferencedMesh",
                      "s.json",
                      {{"s.json", R"({"meshes": [{"file": "gone.obj"}]})"}},
                      "gone.obj",
                      "file not found (referenced by s.json at /meshes/0/file)"},
        FileErrorCase{"SceneReferencingItself",
                      "s.json",
                      {{"s.json", R"({"meshes": [{"file": "s.json"}]})"}},
                      "s.json",
                      "is this scene file itself"},
        FileErrorCase{"SceneReferencingAnotherScene",
                      "s.json",
                      {{"s.json", R"({"meshes": [{"file": "t.json"}]})"},
                       {"t.json", R"({"meshes": [{"file": "s.json"}]})"}},
                      "s.json",
                      "a scene cannot include another scene"},
        FileErrorCase{"AllTrianglesDegenerate",
                      "d.obj",
                      {{"d.obj", "v 0 0 0\nv 1 0 0\nf 1 2 2\n"}},
                      "d.obj",
                      "no geometry: every triangle was degenerate or non-finite (1 degenerate"},
        FileErrorCase{"GltfIndexOutOfRange",
                      kModels + "glTF2/IndexOutOfRange/IndexOutOfRange.gltf",
                      {},
                      kModels + "glTF2/IndexOutOfRange/IndexOutOfRange.gltf",
                      "out of range"},
        FileErrorCase{"GltfWrongTypes",
                      kModels + "glTF2/wrongTypes/badArray.gltf",
                      {},
                      kModels + "glTF2/wrongTypes/badArray.gltf",
                      "was not of type \"array\""},
        FileErrorCase{"GltfInfiniteVertices",
                      kModels + "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
                      {},
                      kModels + "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
                      "12 non-finite"}),
    [](const ::testing::TestParamInfo<FileErrorCase>& info) { return info.param.name; });

TEST_F(CliTest, UnreadableSceneFileIsAnError) {
  if (::geteuid() == 0) GTEST_SKIP() << "running as root, where permission bits do not stop reads";
  WriteText(work_ / "s.json", "{}");
  fs::permissions(work_ / "s.json", fs::perms::none);
  const RunResult r = Run({"render", "s.json"});
  ExpectErrorLine(r, 1, "s.json", "cannot read");
  ExpectOnlyFiles(work_, {"s.json"});
}

TEST_F(CliTest, BadOutputInASceneFileNamesTheSceneFile) {
  WriteText(work_ / "s.json",
            std::string("{\"output\": {\"file\": \"x.gif\"}, \"meshes\": [") + kTriangle + "]}");
  const RunResult r = Run({"render", "s.json"});
  ExpectErrorLine(r, 1, "s.json", "/output/file: 'x.gif' has an unknown extension");
  ExpectOnlyFiles(work_, {"s.json"});
}

// A malformed binary PLY that makes assimp segfault (found by the mesh fuzzer): assimp runs in a
// child process, so tritrace reports it and exits 1 instead of crashing.
TEST_F(CliTest, ModelThatCrashesTheImporterIsAnError) {
  const std::string corpus = ReadFile(std::string(TRITRACE_SOURCE_DIR) +
                                      "/tests/fuzz_corpus/mesh_memory/ply_binary_header_segv");
  ASSERT_GT(corpus.size(), 1u);
  {
    std::ofstream out(work_ / "crash.ply", std::ios::binary);
    out << corpus.substr(1);  // the fuzzer's first byte picks the format; the rest is the file
  }
  const RunResult render = Run({"render", "crash.ply", "-o", "crash.png"});
  ExpectErrorLine(render, 1, "crash.ply", "the importer crashed");
  ExpectOnlyFiles(work_, {"crash.ply"});
  const RunResult info = Run({"info", "crash.ply"});
  ExpectErrorLine(info, 1, "crash.ply", "the importer crashed");
}

// A texture that is not there: one line naming it, exit 1, no image; for a scene file's
// albedo_texture and for a model's map_Kd alike.
TEST_F(CliTest, MissingTextureIsAnError) {
  std::ofstream(work_ / "scene.json")
      << R"({"materials": [{"name": "m", "albedo": [1, 1, 1], "albedo_texture": "gone.png"}],
             "meshes": [{"generator": "cornell", "material": "m"}]})";
  const RunResult scene = Run({"render", "scene.json", "-o", "s.png"});
  ExpectErrorLine(scene, 1, "gone.png", "file not found");
  std::ofstream(work_ / "quad.mtl") << "newmtl m\nKd 1 1 1\nmap_Kd lost.png\n";
  std::ofstream(work_ / "quad.obj")
      << "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl m\n"
         "f 1/1 2/2 3/3\n";
  const RunResult model = Run({"render", "quad.obj", "-o", "q.png"});
  ExpectErrorLine(model, 1, "./lost.png", "cannot read texture: no such file");
  ExpectOnlyFiles(work_, {"quad.mtl", "quad.obj", "scene.json"});
}

// With stderr on a terminal, a render that takes more than about a second shows a progress bar
// with percentage, elapsed time and ETA. `script` (util-linux) gives the command a terminal. The
// render is sized to take a few seconds: brute force, one thread.
TEST_F(CliTest, SlowRenderOnATerminalShowsProgress) {
  const std::string log = (capture_ / "terminal.log").string();
  const std::string command = std::string("cd '") + work_.string() + "' && script -qec \"" +
                              TRITRACE_CLI_PATH +
                              " render --scene terrain:20k --accel brute --threads 1 --width 160"
                              " --height 120 -o p.png\" /dev/null > '" +
                              log + "' 2>&1";
  if (std::system("command -v script > /dev/null") != 0) GTEST_SKIP() << "no script(1)";
  ASSERT_EQ(std::system(command.c_str()), 0);
  const std::string screen = ReadFile(log);
  EXPECT_NE(screen.find("% "), std::string::npos) << screen;
  EXPECT_NE(screen.find("elapsed"), std::string::npos) << screen;
  EXPECT_NE(screen.find("ETA"), std::string::npos) << screen;
  EXPECT_NE(screen.find("rendered 160x120"), std::string::npos) << screen;
}

// Before the render, on a terminal, phases that take more than about 0.3 s show a line with their
// elapsed time: making (or loading) the scene and building its BVH, here the binned SAH over three
// million triangles (an 8 x 8 image would get the much quicker Morton build by default).
TEST_F(CliTest, BigSceneOnATerminalShowsItsPhases) {
  const std::string log = (capture_ / "terminal.log").string();
  const std::string command = std::string("cd '") + work_.string() + "' && script -qec \"" +
                              TRITRACE_CLI_PATH +
                              " render --scene terrain:3m --bvh-build sah --width 8 --height 8 "
                              "-o p.png\" "
                              "/dev/null > '" +
                              log + "' 2>&1";
  if (std::system("command -v script > /dev/null") != 0) GTEST_SKIP() << "no script(1)";
  ASSERT_EQ(std::system(command.c_str()), 0);
  const std::string screen = ReadFile(log);
  const std::regex building(R"(building bvh over [0-9]+ triangles  [0-9]+\.[0-9] s)");
  EXPECT_TRUE(std::regex_search(screen, building)) << screen;
  EXPECT_NE(screen.find("rendered 8x8"), std::string::npos) << screen;
}

// Without a terminal (as in every other test here) no bar is drawn: stderr stays empty.
TEST_F(CliTest, SlowRenderWithoutATerminalPrintsNoProgress) {
  const RunResult r = Run({"render", "--scene", "terrain:20k", "--accel", "brute", "--threads", "1",
                           "--width", "160", "--height", "120", "-o", "p.png"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.err, "");
}

// Without --kernel, brute force renders with the watertight kernel: the same bytes as asking for
// it.
// ---- EXR, AOVs and exposure -----------------------------------------------------------------

using tritrace::testing::ExrContents;
using tritrace::testing::read_exr_channels;

struct PfmImage {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // interleaved, row 0 (top) first
};

// Parses the PFM header this renderer writes ("PF\nW H\n-1.0\n") and flips the rows to top first.
PfmImage ReadPfm(const fs::path& path) {
  const std::string bytes = ReadFile(path);
  std::istringstream in(bytes);
  std::string magic, scale;
  PfmImage pfm;
  in >> magic >> pfm.width >> pfm.height >> scale;
  EXPECT_EQ(magic, "PF");
  EXPECT_EQ(scale, "-1.0");
  const size_t header = static_cast<size_t>(in.tellg()) + 1;  // one newline after the scale
  const size_t row = static_cast<size_t>(pfm.width) * 3;
  EXPECT_EQ(bytes.size(), header + row * pfm.height * sizeof(float));
  pfm.rgb.resize(row * pfm.height);
  if (bytes.size() != header + pfm.rgb.size() * sizeof(float)) return pfm;
  for (int y = 0; y < pfm.height; ++y) {
    const size_t from = header + (static_cast<size_t>(pfm.height - 1 - y) * row) * sizeof(float);
    std::memcpy(pfm.rgb.data() + y * row, bytes.data() + from, row * sizeof(float));
  }
  return pfm;
}

float Channel(const ExrContents& exr, const std::string& name, int x, int y) {
  return exr.channels.at(name).values.at(static_cast<size_t>(y) * exr.width + x);
}

std::set<std::string> ChannelNames(const ExrContents& exr) {
  std::set<std::string> names;
  for (const auto& entry : exr.channels) names.insert(entry.first);
  return names;
}

// The EXR's R, G, B are the PFM's floats bit for bit (both are the same render, unclamped).
void ExpectExrRgbEqualsPfm(const ExrContents& exr, const PfmImage& pfm) {
  ASSERT_EQ(exr.width, pfm.width);
  ASSERT_EQ(exr.height, pfm.height);
  size_t mismatches = 0;
  for (int y = 0; y < exr.height; ++y) {
    for (int x = 0; x < exr.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float want = pfm.rgb[(static_cast<size_t>(y) * pfm.width + x) * 3 + c];
        const float got = Channel(exr, std::string(1, "RGB"[c]), x, y);
        if (std::memcmp(&want, &got, sizeof(float)) != 0 && ++mismatches <= 5) {
          ADD_FAILURE() << "pixel " << x << "," << y << " channel " << c << ": exr " << got
                        << ", pfm " << want;
        }
      }
    }
  }
  EXPECT_EQ(mismatches, 0u);
}

TEST_F(CliTest, LabImageAsExrEqualsTheLabPfm) {
  const std::vector<std::string> size = {"--width", "40", "--height", "30"};
  RenderQuietly(size, "lab.pfm");
  RenderQuietly(size, "lab.exr");
  const ExrContents exr = read_exr_channels((work_ / "lab.exr").string());
  EXPECT_EQ(ChannelNames(exr), (std::set<std::string>{"R", "G", "B"}));
  for (const auto& [name, data] : exr.channels) EXPECT_EQ(data.stored, Imf::FLOAT) << name;
  ExpectExrRgbEqualsPfm(exr, ReadPfm(work_ / "lab.pfm"));
  ExpectOnlyFiles(work_, {"lab.exr", "lab.pfm"});
}

// The lab's one ray through pixel (16, 12)'s corner of a 32 x 32 image leaves the camera at
// (0, 0, -3) along (16 - 16, 12 - 16, 32) = (0, -4, 32): above both blocks (the tall one's top
// is at y = -0.189, and the ray is at y < -0.38 over its footprint) it meets the white back wall
// z = 1 at (0, -0.5, 1), at distance sqrt(0.5^2 + 4^2) = sqrt(16.25) from the camera.
TEST_F(CliTest, LabAovsAtAHandTracedPixel) {
  RenderQuietly({"--width", "32", "--height", "32", "--aovs", "depth,normal,albedo"}, "lab.exr");
  const ExrContents exr = read_exr_channels((work_ / "lab.exr").string());
  EXPECT_EQ(ChannelNames(exr),
            (std::set<std::string>{"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X",
                                   "normal.Y", "normal.Z", "Z"}));
  EXPECT_NEAR(Channel(exr, "Z", 16, 12), std::sqrt(16.25f), 1e-5f);
  EXPECT_EQ(Channel(exr, "normal.X", 16, 12), 0.0f);
  EXPECT_EQ(Channel(exr, "normal.Y", 16, 12), 0.0f);
  EXPECT_EQ(Channel(exr, "normal.Z", 16, 12), -1.0f);  // the wall's normal, facing the camera
  for (const std::string c : {"albedo.R", "albedo.G", "albedo.B"}) {
    EXPECT_EQ(Channel(exr, c, 16, 12), 0.75f) << c;  // the back wall is white, 0.75
  }
  // --aovs changes nothing in the radiance.
  RenderQuietly({"--width", "32", "--height", "32"}, "lab.pfm");
  ExpectExrRgbEqualsPfm(exr, ReadPfm(work_ / "lab.pfm"));
}

TEST_F(CliTest, CornellAreaExrHasTheAovLayersAndTheSameRadianceAsThePfm) {
  const std::vector<std::string> args = {"--scene", "cornell-area", "--spp",    "4",
                                         "--width", "32",           "--height", "32"};
  std::vector<std::string> with_aovs = args;
  with_aovs.insert(with_aovs.end(), {"--aovs", "albedo,normal,depth,variance"});
  RenderQuietly(with_aovs, "x.exr");
  RenderQuietly(args, "x.pfm");
  ExpectOnlyFiles(work_, {"x.exr", "x.pfm"});
  const ExrContents exr = read_exr_channels((work_ / "x.exr").string());
  ASSERT_EQ(exr.width, 32);
  ASSERT_EQ(exr.height, 32);
  EXPECT_EQ(ChannelNames(exr),
            (std::set<std::string>{"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X",
                                   "normal.Y", "normal.Z", "Z", "variance.R", "variance.G",
                                   "variance.B"}));
  for (const auto& [name, data] : exr.channels) EXPECT_EQ(data.stored, Imf::FLOAT) << name;
  ExpectExrRgbEqualsPfm(exr, ReadPfm(work_ / "x.pfm"));

  // Pixel (16, 12)'s four samples look along (u, v - 4, 32) with u, v in [0, 1) and all meet the
  // back wall z = 1 (see LabAovsAtAHandTracedPixel), at distances 4 sqrt(1 + (u^2 + (v-4)^2)/32^2)
  // in (4 sqrt(1 + 9/1024), 4 sqrt(1 + 17/1024)).
  EXPECT_GT(Channel(exr, "Z", 16, 12), 4.0f * std::sqrt(1.0f + 9.0f / 1024.0f));
  EXPECT_LT(Channel(exr, "Z", 16, 12), 4.0f * std::sqrt(1.0f + 17.0f / 1024.0f));
  EXPECT_EQ(Channel(exr, "normal.Z", 16, 12), -1.0f);
  EXPECT_EQ(Channel(exr, "albedo.G", 16, 12), 0.75f);
  // Every pixel sees some surface of the closed-looking box: unit-or-shorter normals (means of
  // unit normals), albedos within [0, 1], positive depths, finite non-negative radiance and
  // variance.
  int positive_variances = 0;
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      const float nx = Channel(exr, "normal.X", x, y), ny = Channel(exr, "normal.Y", x, y),
                  nz = Channel(exr, "normal.Z", x, y);
      EXPECT_LE(nx * nx + ny * ny + nz * nz, 1.0f + 1e-5f) << x << "," << y;
      EXPECT_GT(Channel(exr, "Z", x, y), 0.0f) << x << "," << y;
      for (const std::string c : {"albedo.R", "albedo.G", "albedo.B"}) {
        EXPECT_GE(Channel(exr, c, x, y), 0.0f);
        EXPECT_LE(Channel(exr, c, x, y), 1.0f);
      }
      for (const std::string c : {"R", "G", "B"}) {
        EXPECT_TRUE(std::isfinite(Channel(exr, c, x, y)) && Channel(exr, c, x, y) >= 0.0f);
      }
      for (const std::string c : {"variance.R", "variance.G", "variance.B"}) {
        const float v = Channel(exr, c, x, y);
        EXPECT_TRUE(std::isfinite(v) && v >= 0.0f) << c << " " << x << "," << y;
        positive_variances += v > 0.0f;
      }
    }
  }
  // Four samples of a noisy path render: two differing halves almost everywhere.
  EXPECT_GT(positive_variances, 3 * 32 * 32 / 2);
}

// The AOVs follow paths through the glass sphere, but the radiance stays the image rendered without
// them (no random number is drawn for them), and so does a file with only depth.
TEST_F(CliTest, AovsThroughGlassLeaveTheRadianceUnchanged) {
  const std::vector<std::string> args = {std::string(TRITRACE_SOURCE_DIR) + "/scenes/glass.json",
                                         "--spp",
                                         "4",
                                         "--width",
                                         "40",
                                         "--height",
                                         "40"};
  std::vector<std::string> with_aovs = args;
  with_aovs.insert(with_aovs.end(), {"--aovs", "albedo,normal,depth,variance"});
  RenderQuietly(with_aovs, "g.exr");
  RenderQuietly(args, "g.pfm");
  ExpectExrRgbEqualsPfm(read_exr_channels((work_ / "g.exr").string()), ReadPfm(work_ / "g.pfm"));
}

TEST_F(CliTest, ExrHalfStoresHalfColourAndFloatDepth) {
  const std::vector<std::string> args = {
      "--scene", "cornell-area", "--spp", "2",      "--width",
      "24",      "--height",     "24",    "--aovs", "normal,depth,variance"};
  RenderQuietly(args, "f.exr");
  std::vector<std::string> half = args;
  half.push_back("--exr-half");
  RenderQuietly(half, "h.exr");
  const ExrContents f = read_exr_channels((work_ / "f.exr").string());
  const ExrContents h = read_exr_channels((work_ / "h.exr").string());
  EXPECT_EQ(ChannelNames(h),
            (std::set<std::string>{"R", "G", "B", "normal.X", "normal.Y", "normal.Z", "Z",
                                   "variance.R", "variance.G", "variance.B"}));
  for (const auto& [name, data] : h.channels) {
    const bool full = name == "Z" || name.starts_with("variance.");
    EXPECT_EQ(data.stored, full ? Imf::FLOAT : Imf::HALF) << name;
    for (size_t i = 0; i < data.values.size(); ++i) {
      const float want = f.channels.at(name).values[i];
      if (full) {
        EXPECT_EQ(data.values[i], want);
      } else {
        // Half rounds to 11 significant bits; below 2^-14 its steps are 2^-24.
        EXPECT_LE(std::fabs(data.values[i] - want), std::max(std::fabs(want) * 0x1p-11f, 0x1p-25f))
            << name << " " << i;
      }
    }
  }
  EXPECT_LT(fs::file_size(work_ / "h.exr"), fs::file_size(work_ / "f.exr"));
}

// 255 (1.055 c^(1/2.4) - 0.055), or 255 * 12.92 c at or below 0.0031308, in double precision:
// the IEC 61966-2-1 curve computed apart from the renderer's float one.
double SrgbTimes255(double c) {
  if (!(c > 0.0)) return 0.0;
  if (c >= 1.0) return 255.0;
  return 255.0 * (c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055);
}

TEST_F(CliTest, ExposureScalesPathImagesBeforeTheSrgbCurve) {
  const std::vector<std::string> args = {"--scene", "cornell-area", "--spp",    "2",
                                         "--width", "24",           "--height", "24"};
  RenderQuietly(args, "linear.pfm");
  const std::string plain = RenderQuietly(args, "plain.ppm");
  std::vector<std::string> zero = args;
  zero.insert(zero.end(), {"--exposure", "0"});
  EXPECT_EQ(RenderQuietly(zero, "zero.ppm"), plain);
  std::vector<std::string> plus = args;
  plus.insert(plus.end(), {"--exposure", "1.5"});
  RenderQuietly(plus, "plus.ppm");

  const PfmImage linear = ReadPfm(work_ / "linear.pfm");
  const tritrace::Rgb8Image bright = tritrace::read_image_rgb8((work_ / "plus.ppm").string());
  ASSERT_EQ(bright.rgb.size(), linear.rgb.size());
  size_t exact = 0, brighter = 0;
  const std::string plain_rgb = plain.substr(plain.size() - linear.rgb.size());
  for (size_t i = 0; i < linear.rgb.size(); ++i) {
    const double expected = SrgbTimes255(std::exp2(1.5) * linear.rgb[i]);
    // Float and double arithmetic may round a value lying within a hair of .5 differently.
    EXPECT_NEAR(bright.rgb[i], expected, 0.5 + 1e-3) << "byte " << i;
    exact += bright.rgb[i] == std::lround(expected);
    brighter += bright.rgb[i] > static_cast<uint8_t>(plain_rgb[i]);
  }
  EXPECT_GE(exact, linear.rgb.size() - 2);
  EXPECT_GT(brighter, linear.rgb.size() / 2);
}

TEST_F(CliTest, BruteForceDefaultsToTheWatertightKernel) {
  const std::vector<std::string> size = {"--width", "96", "--height", "96", "--accel", "brute"};
  auto with = [&](std::vector<std::string> extra, const std::string& out) {
    std::vector<std::string> args = {"render", "-o", out};
    args.insert(args.end(), size.begin(), size.end());
    args.insert(args.end(), extra.begin(), extra.end());
    EXPECT_EQ(Run(args).exit_code, 0);
    return ReadFile(work_ / out);
  };
  const std::string by_default = with({}, "default.ppm");
  EXPECT_EQ(by_default, with({"--kernel", "watertight"}, "watertight.ppm"));
  EXPECT_FALSE(by_default.empty());
}

// Distributed rendering (docs/DISTRIBUTED.md): partial films of sample ranges and tile parts merge
// into the bytes of the one-process image; merge names what is missing, overlapping or foreign.
class DistributedCliTest : public CliTest {
 protected:
  // cornell-area at 40 x 40 (9 tiles of 16 x 16), 20 spp: two whole blocks of 8 and a partial one.
  std::vector<std::string> Scene(std::vector<std::string> extra = {}) const {
    std::vector<std::string> args = {"render",  "--scene", "cornell-area", "--spp", "20",
                                     "--width", "40",      "--height",     "40",    "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
  void RenderPart(const std::string& name, std::vector<std::string> flags) {
    flags.insert(flags.end(), {"-o", name});
    const RunResult r = Run(Scene(flags));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(r.err, "");
  }
  RunResult Merge(std::vector<std::string> parts, const std::string& output) {
    std::vector<std::string> args = {"merge"};
    args.insert(args.end(), parts.begin(), parts.end());
    args.insert(args.end(), {"-o", output, "-q"});
    return Run(args);
  }
  std::string Whole(const std::string& name, std::vector<std::string> flags = {}) {
    flags.insert(flags.end(), {"-o", name});
    const RunResult r = Run(Scene(flags));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return ReadFile(work_ / name);
  }
};

TEST_F(DistributedCliTest, SampleRangesMergeIntoTheOneProcessImageBitForBit) {
  const std::string whole = Whole("whole.pfm");
  ASSERT_FALSE(whole.empty());
  RenderPart("a.exr", {"--spp-range", "0:8"});
  RenderPart("b.exr", {"--spp-range", "8:16"});
  RenderPart("c.exr", {"--spp-range", "16:20"});
  RenderPart("ab.exr", {"--spp-range", "0:16"});
  RenderPart("bc.exr", {"--spp-range", "8:20"});
  RenderPart("abc.exr", {"--spp-range", "0:20"});
  const std::vector<std::vector<std::string>> splits = {{"a.exr", "b.exr", "c.exr"},
                                                        {"c.exr", "a.exr", "b.exr"},
                                                        {"ab.exr", "c.exr"},
                                                        {"a.exr", "bc.exr"},
                                                        {"abc.exr"}};
  for (const auto& parts : splits) {
    const RunResult r = Merge(parts, "merged.pfm");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(ReadFile(work_ / "merged.pfm") == whole) << "parts " << parts[0] << "...";
  }
  // The 8-bit output too, through the same curve as render.
  const std::string png = Whole("whole.png");
  ASSERT_EQ(Merge({"a.exr", "bc.exr"}, "merged.png").exit_code, 0);
  EXPECT_TRUE(ReadFile(work_ / "merged.png") == png);
}

TEST_F(DistributedCliTest, TilePartsAndRangesOfTilesMergeBitForBit) {
  const std::string whole = Whole("whole.pfm");
  std::vector<std::string> tiles, mixed;
  for (const char* i : {"0", "1", "2", "3"}) {
    const std::string name = std::string("t") + i + ".exr";
    RenderPart(name, {"--tile", std::string(i) + "/4"});
    tiles.push_back(name);
  }
  ASSERT_EQ(Merge(tiles, "tiles.pfm").exit_code, 0);
  EXPECT_TRUE(ReadFile(work_ / "tiles.pfm") == whole);
  // Each of 3 tile parts split into its own sample ranges, differently per tile.
  const std::vector<std::vector<std::string>> parts = {{"0/3", "0:8", "m0a.exr"},
                                                       {"0/3", "8:20", "m0b.exr"},
                                                       {"1/3", "0:16", "m1a.exr"},
                                                       {"1/3", "16:20", "m1b.exr"},
                                                       {"2/3", "0:20", "m2.exr"}};
  for (const std::vector<std::string>& p : parts) {
    RenderPart(p[2], {"--tile", p[0], "--spp-range", p[1]});
    mixed.push_back(p[2]);
  }
  const RunResult r = Merge(mixed, "mixed.pfm");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(ReadFile(work_ / "mixed.pfm") == whole);
}

// Adaptive sampling decides per pixel from its own samples: tile parts (the spp AOV included)
// merge into the one-process file byte for byte, and the summary names the threshold and the
// mean spp. A sample range is a usage error.
TEST_F(DistributedCliTest, AdaptiveTilePartsMergeBitForBit) {
  const auto adaptive = [](std::vector<std::string> extra) {
    std::vector<std::string> args = {
        "render", "--scene", "cornell-area",      "--spp", "128", "--width", "40", "--height", "40",
        "--aovs", "spp",     "--noise-threshold", "0.05"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const RunResult whole = Run(adaptive({"-o", "whole.exr", "--threads", "1"}));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  EXPECT_NE(whole.out.find("128 spp at most (mean "), std::string::npos) << whole.out;
  EXPECT_NE(whole.out.find("noise threshold 0.05)"), std::string::npos) << whole.out;
  std::vector<std::string> tiles;
  for (const char* i : {"0", "1", "2"}) {
    const std::string name = std::string("t") + i + ".exr";
    const RunResult r = Run(adaptive({"--tile", std::string(i) + "/3", "-o", name, "-q"}));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    tiles.push_back(name);
  }
  const RunResult merged = Merge(tiles, "merged.exr");
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  EXPECT_TRUE(ReadExrWithoutTimes(work_ / "merged.exr") ==
              ReadExrWithoutTimes(work_ / "whole.exr"));
  // Uniform sampling makes another file.
  ASSERT_EQ(Run({"render", "--scene", "cornell-area", "--spp", "128", "--width", "40", "--height",
                 "40", "--aovs", "spp", "-o", "uniform.exr"})
                .exit_code,
            0);
  EXPECT_FALSE(ReadFile(work_ / "uniform.exr") == ReadFile(work_ / "whole.exr"));

  const RunResult range = Run(adaptive({"--spp-range", "0:32", "-o", "r.exr"}));
  EXPECT_EQ(range.exit_code, 2);
  EXPECT_NE(range.err.find("--noise-threshold"), std::string::npos) << range.err;
  const RunResult bad = Run(adaptive({"--noise-threshold", "2", "-o", "b.exr"}));
  EXPECT_EQ(bad.exit_code, 2);
}

// The EXR's header records the render: spp, the mean spp under adaptive sampling (the mean of the
// spp layer, read back with OpenEXR), the render time, the time limit and the threshold, and why
// it stopped; a merge of tile parts records the whole render's, and the summary line says the
// same. A generous time limit gives the threshold alone's image; a tiny one stops after the first
// pass of 8 and says so.
TEST_F(DistributedCliTest, TheExrHeaderRecordsSppTimeLimitAndThreshold) {
  const auto adaptive = [](std::vector<std::string> extra) {
    std::vector<std::string> args = {
        "render", "--scene", "cornell-area",      "--spp", "128", "--width", "40", "--height", "40",
        "--aovs", "spp",     "--noise-threshold", "0.05"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const auto mean_spp = [](const ExrContents& e) {
    double sum = 0.0;
    for (float v : e.channels.at("spp").values) sum += v;
    return sum / static_cast<double>(e.channels.at("spp").values.size());
  };
  const RunResult alone = Run(adaptive({"-o", "alone.exr"}));
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  const ExrContents a = read_exr_channels((work_ / "alone.exr").string());
  EXPECT_EQ(a.numbers.at("tritrace.spp"), 128.0);
  EXPECT_EQ(a.numbers.at("tritrace.noiseThreshold"), static_cast<double>(0.05f));
  EXPECT_EQ(a.numbers.at("tritrace.meanSpp"), static_cast<double>(static_cast<float>(mean_spp(a))));
  EXPECT_LT(a.numbers.at("tritrace.meanSpp"), 128.0);
  EXPECT_GT(a.numbers.at("tritrace.renderSeconds"), 0.0);
  EXPECT_EQ(a.numbers.count("tritrace.timeLimit"), 0u);
  EXPECT_EQ(a.strings.at("tritrace.stoppedBy"), "spp");
  // The summary's render time is the header's (ms there, seconds here, both rounded).
  std::smatch ms;
  ASSERT_TRUE(std::regex_search(alone.out, ms, std::regex(" in ([0-9.]+) ms"))) << alone.out;
  EXPECT_NEAR(std::stod(ms[1]) * 1e-3, a.numbers.at("tritrace.renderSeconds"), 1e-3);

  const RunResult generous = Run(adaptive({"--time-limit", "100000", "-o", "generous.exr"}));
  ASSERT_EQ(generous.exit_code, 0) << generous.err;
  EXPECT_NE(generous.out.find("(time limit 100000 s: "), std::string::npos) << generous.out;
  const ExrContents g = read_exr_channels((work_ / "generous.exr").string());
  for (const char* c : {"R", "G", "B", "spp"}) {
    EXPECT_EQ(g.channels.at(c).values, a.channels.at(c).values) << c;
  }
  EXPECT_EQ(g.numbers.at("tritrace.timeLimit"), 100000.0);
  EXPECT_EQ(g.numbers.at("tritrace.meanSpp"), a.numbers.at("tritrace.meanSpp"));

  const RunResult tiny = Run(adaptive({"--time-limit", "1e-9", "-o", "tiny.exr"}));
  ASSERT_EQ(tiny.exit_code, 0) << tiny.err;
  EXPECT_NE(tiny.out.find("rendered 40x40, 8 spp at most (mean 8.0 spp, noise threshold 0.05)"),
            std::string::npos)
      << tiny.out;
  EXPECT_NE(tiny.out.find("(time limit 1e-9 s: stopped by the time limit)"), std::string::npos)
      << tiny.out;
  const ExrContents t = read_exr_channels((work_ / "tiny.exr").string());
  EXPECT_EQ(t.numbers.at("tritrace.spp"), 8.0);
  EXPECT_EQ(t.numbers.at("tritrace.meanSpp"), 8.0);
  EXPECT_EQ(t.numbers.at("tritrace.timeLimit"), static_cast<double>(1e-9f));
  EXPECT_EQ(t.strings.at("tritrace.stoppedBy"), "time limit");

  // Tile parts merged: the whole render's spp, mean spp and threshold; its own time.
  std::vector<std::string> tiles;
  for (const char* i : {"0", "1"}) {
    const std::string name = std::string("t") + i + ".exr";
    ASSERT_EQ(Run(adaptive({"--tile", std::string(i) + "/2", "-o", name, "-q"})).exit_code, 0);
    tiles.push_back(name);
  }
  ASSERT_EQ(Merge(tiles, "merged.exr").exit_code, 0);
  const ExrContents m = read_exr_channels((work_ / "merged.exr").string());
  for (const char* key : {"tritrace.spp", "tritrace.meanSpp", "tritrace.noiseThreshold"}) {
    EXPECT_EQ(m.numbers.at(key), a.numbers.at(key)) << key;
  }
  EXPECT_GE(m.numbers.at("tritrace.renderSeconds"), 0.0);

  // Uniform sampling: spp and the time only.
  ASSERT_EQ(Run({"render", "--scene", "cornell-area", "--spp", "16", "--width", "16", "--height",
                 "16", "-o", "uniform.exr", "-q"})
                .exit_code,
            0);
  const ExrContents u = read_exr_channels((work_ / "uniform.exr").string());
  EXPECT_EQ(u.numbers.at("tritrace.spp"), 16.0);
  EXPECT_EQ(u.numbers.count("tritrace.meanSpp"), 0u);
  EXPECT_EQ(u.numbers.count("tritrace.noiseThreshold"), 0u);
}

TEST_F(DistributedCliTest, AovsAndTheLabImageMergeBitForBit) {
  Whole("whole.exr", {"--aovs", "albedo,normal,depth,variance"});
  const std::string whole = ReadExrWithoutTimes(work_ / "whole.exr");
  RenderPart("a.exr", {"--aovs", "albedo,normal,depth,variance", "--spp-range", "0:8"});
  RenderPart("b.exr", {"--aovs", "albedo,normal,depth,variance", "--spp-range", "8:20"});
  ASSERT_EQ(Merge({"a.exr", "b.exr"}, "merged.exr").exit_code, 0);
  EXPECT_TRUE(ReadExrWithoutTimes(work_ / "merged.exr") == whole) << "radiance and every AOV";
  // Tile parts of sample ranges, the variance's half buffers included.
  RenderPart("t0a.exr", {"--aovs", "variance", "--tile", "0/2", "--spp-range", "0:8"});
  RenderPart("t0b.exr", {"--aovs", "variance", "--tile", "0/2", "--spp-range", "8:20"});
  RenderPart("t1.exr", {"--aovs", "variance", "--tile", "1/2"});
  Whole("variance.exr", {"--aovs", "variance"});
  const std::string variance_only = ReadExrWithoutTimes(work_ / "variance.exr");
  ASSERT_EQ(Merge({"t1.exr", "t0b.exr", "t0a.exr"}, "tiles.exr").exit_code, 0);
  EXPECT_TRUE(ReadExrWithoutTimes(work_ / "tiles.exr") == variance_only)
      << "variance from tile parts";

  const std::vector<std::string> lab = {"render", "--width", "40", "--height", "40", "-q"};
  auto run_lab = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = lab;
    args.insert(args.end(), extra.begin(), extra.end());
    return Run(args);
  };
  ASSERT_EQ(run_lab({"-o", "lab.png"}).exit_code, 0);
  ASSERT_EQ(run_lab({"--tile", "0/2", "-o", "l0.exr"}).exit_code, 0);
  ASSERT_EQ(run_lab({"--tile", "1/2", "-o", "l1.exr"}).exit_code, 0);
  ASSERT_EQ(Merge({"l1.exr", "l0.exr"}, "lab_merged.png").exit_code, 0);
  EXPECT_TRUE(ReadFile(work_ / "lab_merged.png") == ReadFile(work_ / "lab.png"));
  const RunResult r = run_lab({"--spp-range", "0:1", "-o", "x.exr"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--tile"), std::string::npos) << r.err;
}

TEST_F(DistributedCliTest, MergeNamesMissingOverlappingAndForeignParts) {
  RenderPart("a.exr", {"--spp-range", "0:8"});
  RenderPart("b.exr", {"--spp-range", "8:16"});
  RenderPart("c.exr", {"--spp-range", "16:20"});
  RenderPart("bc.exr", {"--spp-range", "8:20"});
  RenderPart("seed.exr", {"--spp-range", "16:20", "--seed", "3"});
  RenderPart("t1.exr", {"--tile", "1/2"});
  auto expect_error = [&](std::vector<std::string> parts, const std::vector<std::string>& words) {
    const RunResult r = Merge(parts, "out.png");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_EQ(CountLines(r.err), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("tritrace: ", 0), 0u) << r.err;
    for (const std::string& w : words) EXPECT_NE(r.err.find(w), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(work_ / "out.png")) << "no output on error";
  };
  expect_error({"a.exr", "c.exr"}, {"missing", "samples [8, 16)"});
  expect_error({"a.exr", "b.exr"}, {"missing", "samples [16, 20)"});
  expect_error({"a.exr", "b.exr", "bc.exr"}, {"bc.exr", "overlaps b.exr", "samples [8, 16)"});
  expect_error({"a.exr", "a.exr", "bc.exr"}, {"overlaps", "samples [0, 8)"});
  expect_error({"a.exr", "b.exr", "seed.exr"}, {"seed.exr", "foreign part", "seed=3"});
  expect_error({"a.exr", "t1.exr"}, {"t1.exr", "tile"});
  expect_error({"t1.exr"}, {"missing", "tile 0/2"});
  // Not a partial film at all: the merged output of another merge, or a missing file.
  ASSERT_EQ(Merge({"a.exr", "bc.exr"}, "whole.exr").exit_code, 0);
  expect_error({"whole.exr"}, {"whole.exr", "not a tritrace partial film"});
  expect_error({"nope.exr"}, {"nope.exr"});
}

// brute, bvh and bvh-single give the same bytes with one kernel, so their parts merge; a part
// rendered with another kernel is foreign, and the message says which setting differs.
TEST_F(DistributedCliTest, AccelsWithOneKernelMergeAndAnotherKernelIsForeign) {
  const std::string whole = Whole("whole.pfm");
  RenderPart("a.exr", {"--spp-range", "0:8", "--accel", "brute"});
  RenderPart("b.exr", {"--spp-range", "8:16", "--accel", "bvh-single"});
  RenderPart("c.exr", {"--spp-range", "16:20", "--accel", "bvh"});
  RenderPart("mt.exr", {"--spp-range", "16:20", "--kernel", "moller-trumbore"});
  const RunResult r = Merge({"a.exr", "b.exr", "c.exr"}, "merged.pfm");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(ReadFile(work_ / "merged.pfm") == whole);
  const RunResult foreign = Merge({"a.exr", "b.exr", "mt.exr"}, "out.pfm");
  EXPECT_EQ(foreign.exit_code, 1);
  EXPECT_EQ(CountLines(foreign.err), 1u) << foreign.err;
  EXPECT_NE(foreign.err.find("mt.exr: foreign part"), std::string::npos) << foreign.err;
  EXPECT_NE(foreign.err.find("kernel=moller-trumbore"), std::string::npos) << foreign.err;
  EXPECT_FALSE(fs::exists(work_ / "out.pfm"));
}

// A part from another build (here: its header's commit altered, the file otherwise intact) is
// refused, naming both builds.
TEST_F(DistributedCliTest, PartsOfAnotherBuildAreForeign) {
  RenderPart("a.exr", {"--spp-range", "0:8"});
  RenderPart("b.exr", {"--spp-range", "8:20"});
  std::string bytes = ReadFile(work_ / "b.exr");
  const size_t at = bytes.find("commit=");
  ASSERT_NE(at, std::string::npos);
  bytes[at + 7] = 'z';  // never a hex digit
  std::ofstream(work_ / "b.exr", std::ios::binary) << bytes;
  const RunResult r = Merge({"a.exr", "b.exr"}, "out.pfm");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(CountLines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("b.exr: foreign part: built by another tritrace: version="),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("commit=z"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(", not version="), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(work_ / "out.pfm"));
}

// A part cut short (a copy that did not finish) is one line naming it, before anything is merged.
TEST_F(DistributedCliTest, TruncatedPartIsNamed) {
  RenderPart("a.exr", {"--spp-range", "0:8"});
  RenderPart("b.exr", {"--spp-range", "8:20"});
  const std::string bytes = ReadFile(work_ / "b.exr");
  ASSERT_GT(bytes.size(), 3000u);
  std::ofstream(work_ / "b.exr", std::ios::binary) << bytes.substr(0, 2000);
  const RunResult r = Merge({"a.exr", "b.exr"}, "out.pfm");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(CountLines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("tritrace: b.exr: truncated partial film: 2000 bytes, but chunk ", 0), 0u)
      << r.err;
  EXPECT_FALSE(fs::exists(work_ / "out.pfm"));
}

TEST_F(DistributedCliTest, BadSplitsAreRefusedBeforeRendering) {
  auto expect_usage = [&](std::vector<std::string> flags, const std::string& flag,
                          const std::string& words) {
    const RunResult r = Run(Scene(flags));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(CountLines(r.err), 1u) << r.err;
    EXPECT_EQ(r.err.rfind("tritrace: " + flag + ": ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << r.err;
    EXPECT_TRUE(ListFolder(work_).empty()) << "no file written";
  };
  expect_usage({"--spp-range", "4:16", "-o", "p.exr"}, "--spp-range", "multiples of 8");
  expect_usage({"--spp-range", "0:12", "-o", "p.exr"}, "--spp-range", "multiples of 8");
  expect_usage({"--spp-range", "8:8", "-o", "p.exr"}, "--spp-range", "not a range");
  expect_usage({"--spp-range", "0:24", "-o", "p.exr"}, "--spp-range", "not a range");
  expect_usage({"--spp-range", "x", "-o", "p.exr"}, "--spp-range", "A:B");
  expect_usage({"--spp-range", "0:8", "-o", "p.png"}, "--spp-range", "OpenEXR");
  expect_usage({"--tile", "4/4", "-o", "p.exr"}, "--tile", "I/N");
  expect_usage({"--tile", "0/10", "-o", "p.exr"}, "--tile", "only 9 tiles");
  expect_usage({"--tile", "0/2", "--exr-half", "-o", "p.exr"}, "--exr-half", "32-bit");
}

TEST_F(DistributedCliTest, InfoPrintsAPartsMetadata) {
  RenderPart("p.exr", {"--spp-range", "8:20", "--tile", "1/3", "--seed", "5"});
  const RunResult r = Run({"info", "p.exr"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const std::string line :
       {"file: p.exr\n", "partial film: samples [8, 20) of tile 1/3 of 20 spp\n",
        "integrator: path\n", "seed: 5\n", "spp: 20\n", "size: 40x40\n", "samples: 8:20\n",
        "tile: 1/3\n", "aovs: none\n"}) {
    EXPECT_NE(r.out.find(line), std::string::npos) << line << " in\n" << r.out;
  }
  EXPECT_TRUE(std::regex_search(r.out, std::regex("render: [0-9a-f]{16}\n"))) << r.out;
  EXPECT_NE(r.out.find("settings: integrator=path spp=20 "), std::string::npos) << r.out;
}

// bdpt's light tracing splats onto any pixel; its light image is an integer sum carried by the
// partial film, so sample ranges merge into the one-process image byte for byte, in any order.
// A tile part cannot hold splats that land outside it: --tile with bdpt is a usage error.
TEST_F(DistributedCliTest, BdptPartsMergeBitForBit) {
  const std::string whole = Whole("whole.pfm", {"--integrator", "bdpt"});
  ASSERT_FALSE(whole.empty());
  RenderPart("b.exr", {"--integrator", "bdpt", "--spp-range", "8:20"});
  RenderPart("a.exr", {"--integrator", "bdpt", "--spp-range", "0:8"});
  const RunResult r = Merge({"b.exr", "a.exr"}, "merged.pfm");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(ReadFile(work_ / "merged.pfm") == whole);
  // A part of the path tracer's render is foreign to bdpt's.
  RenderPart("p.exr", {"--spp-range", "0:8"});
  EXPECT_NE(Merge({"p.exr", "b.exr"}, "mixed.pfm").exit_code, 0);
  const RunResult tile = Run(Scene({"--integrator", "bdpt", "--tile", "0/2", "-o", "t.exr"}));
  EXPECT_EQ(tile.exit_code, 2);
  EXPECT_NE(tile.err.find("--tile"), std::string::npos) << tile.err;
}

// ---- denoise -------------------------------------------------------------------------------

// The median squared difference between horizontally neighbouring pixels' red values: the
// noise (edges are too few to move the median).
double NeighbourDifference(const std::vector<float>& red, int width, int height) {
  std::vector<double> squares;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x + 1 < width; ++x) {
      const double d =
          red[static_cast<size_t>(y) * width + x + 1] - red[static_cast<size_t>(y) * width + x];
      squares.push_back(d * d);
    }
  }
  std::nth_element(squares.begin(), squares.begin() + squares.size() / 2, squares.end());
  return squares[squares.size() / 2];
}

double Mean(const std::vector<float>& values) {
  double sum = 0.0;
  for (float v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

TEST_F(CliTest, DenoiseWritesALessNoisyImageWithTheInputsLayers) {
  RenderQuietly({"--scene", "cornell-area", "--width", "64", "--height", "64", "--spp", "4",
                 "--aovs", "albedo,normal,depth"},
                "in.exr");
  const RunResult r = Run({"denoise", "in.exr", "-o", "out.exr"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_TRUE(std::regex_match(
      r.out, std::regex(R"(denoised in\.exr \(64x64, variance estimated from the image\) in )"
                        R"([0-9]+(\.[0-9]+)? ms to out\.exr\n)")))
      << r.out;
  ExpectOnlyFiles(work_, {"in.exr", "out.exr"});
  const auto in = tritrace::testing::read_exr_channels((work_ / "in.exr").string());
  const auto out = tritrace::testing::read_exr_channels((work_ / "out.exr").string());
  for (const char* name : {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X",
                           "normal.Y", "normal.Z", "Z"}) {
    ASSERT_EQ(out.channels.count(name), 1u) << name;
  }
  EXPECT_EQ(out.channels.at("albedo.G").values, in.channels.at("albedo.G").values);
  EXPECT_EQ(out.channels.at("Z").values, in.channels.at("Z").values);
  const auto& red_in = in.channels.at("R").values;
  const auto& red_out = out.channels.at("R").values;
  EXPECT_LT(NeighbourDifference(red_out, 64, 64), 0.5 * NeighbourDifference(red_in, 64, 64));
  EXPECT_NEAR(Mean(red_out) / Mean(red_in), 1.0, 0.02);
}

// render --denoise is the render's AOVs denoised: the same bytes as writing them to an EXR and
// running `tritrace denoise` on it, as a merged distributed render would be denoised.
TEST_F(CliTest, RenderDenoiseIsDenoiseOfTheRendersLayers) {
  const std::vector<std::string> scene = {"--scene",  "cornell-area", "--width", "48",
                                          "--height", "40",           "--spp",   "8"};
  std::vector<std::string> denoised = scene;
  denoised.push_back("--denoise");
  RenderQuietly(denoised, "direct.pfm");
  std::vector<std::string> layers = scene;
  for (const char* a : {"--aovs", "albedo,normal,depth,variance"}) layers.push_back(a);
  RenderQuietly(layers, "layers.exr");
  const RunResult r = Run({"denoise", "layers.exr", "-o", "later.pfm", "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadFile(work_ / "direct.pfm"), ReadFile(work_ / "later.pfm"));
  RenderQuietly(scene, "noisy.pfm");
  EXPECT_NE(ReadFile(work_ / "direct.pfm"), ReadFile(work_ / "noisy.pfm"));
  const RunResult lab = Run({"render", "--denoise", "-o", "lab.png"});
  ExpectErrorLine(lab, 2, "--denoise", "applies to the path tracer");
}

// A merge of bdpt's parts records the share of light subpaths the one-process render records
// (tritrace.lightPaths, tritrace.lightPathsChosenBy): the share given. With auto (the default) the
// parts carry no choice, so the merged header says auto and no share.
TEST_F(DistributedCliTest, BdptMergeRecordsTheShareOfLightPaths) {
  for (const std::string share : {"0.25", "1", "auto", ""}) {
    std::vector<std::string> flags = {"--integrator", "bdpt"};
    if (!share.empty()) flags.insert(flags.end(), {"--light-paths", share});
    Whole("whole.exr", flags);
    std::vector<std::string> a = flags, b = flags;
    a.insert(a.end(), {"--spp-range", "0:8"});
    b.insert(b.end(), {"--spp-range", "8:20"});
    RenderPart("a.exr", a);
    RenderPart("b.exr", b);
    ASSERT_EQ(Merge({"a.exr", "b.exr"}, "merged.exr").exit_code, 0);
    const ExrContents whole = read_exr_channels((work_ / "whole.exr").string());
    const ExrContents merged = read_exr_channels((work_ / "merged.exr").string());
    if (share == "auto" || share.empty()) {
      EXPECT_EQ(whole.strings.at("tritrace.lightPathsChosenBy"), "auto");
      EXPECT_EQ(merged.strings.at("tritrace.lightPathsChosenBy"), "auto");
      EXPECT_EQ(merged.numbers.count("tritrace.lightPaths"), 0u);
    } else {
      const double expected = std::stod(share);
      EXPECT_EQ(whole.numbers.at("tritrace.lightPaths"), expected) << share;
      EXPECT_EQ(merged.numbers.at("tritrace.lightPaths"), expected) << share;
      EXPECT_EQ(whole.strings.at("tritrace.lightPathsChosenBy"), "setting");
      EXPECT_EQ(merged.strings.at("tritrace.lightPathsChosenBy"), "setting");
    }
  }
}

// The EXR records the path tracer's sampler (tritrace.sampler), and `tritrace denoise` divides the
// variance layer by that sampler's overestimate, so a render with --sampler independent denoises
// later as render --denoise did. A file without the attribute (as tritrace wrote before) is taken
// as Sobol: its layers rewritten without any attribute denoise as the Sobol render's file does,
// and not as the independent one's. Another value is refused naming the file.
TEST_F(CliTest, DenoiseReadsTheSamplerTheFileRecords) {
  const std::vector<std::string> scene = {"--scene",  "cornell-area", "--width", "32",
                                          "--height", "24",           "--spp",   "8"};
  const std::array<std::array<std::string, 3>, 5> layers = {
      {{"R", "G", "B"},
       {"albedo.R", "albedo.G", "albedo.B"},
       {"normal.X", "normal.Y", "normal.Z"},
       {"Z", "Z", "Z"},
       {"variance.R", "variance.G", "variance.B"}}};
  for (const char* sampler : {"sobol", "independent"}) {
    const std::string name(sampler);
    std::vector<std::string> args = scene;
    for (const char* a : {"--sampler", sampler}) args.push_back(a);
    std::vector<std::string> denoised = args;
    denoised.push_back("--denoise");
    RenderQuietly(denoised, name + "_direct.pfm");
    for (const char* a : {"--aovs", "albedo,normal,depth,variance"}) args.push_back(a);
    RenderQuietly(args, name + ".exr");
    EXPECT_EQ(tritrace::testing::read_exr_channels((work_ / (name + ".exr")).string())
                  .strings.at("tritrace.sampler"),
              name);
    const RunResult r = Run({"denoise", name + ".exr", "-o", name + "_later.pfm"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("variance from its layer, " + name + " sampler"), std::string::npos)
        << r.out;
    EXPECT_EQ(ReadFile(work_ / (name + "_direct.pfm")), ReadFile(work_ / (name + "_later.pfm")))
        << name;
    // The same layers with no header attributes.
    const std::vector<tritrace::Image> in =
        tritrace::read_exr_layers((work_ / (name + ".exr")).string(), layers);
    tritrace::write_exr(in[0], (work_ / (name + "_old.exr")).string(),
                        {in[1], in[2], in[3], in[4], tritrace::Image()});
    ASSERT_EQ(Run({"denoise", name + "_old.exr", "-o", name + "_old.pfm", "-q"}).exit_code, 0);
  }
  EXPECT_EQ(ReadFile(work_ / "sobol_old.pfm"), ReadFile(work_ / "sobol_later.pfm"));
  EXPECT_NE(ReadFile(work_ / "independent_old.pfm"), ReadFile(work_ / "independent_later.pfm"));

  const std::vector<tritrace::Image> in =
      tritrace::read_exr_layers((work_ / "sobol.exr").string(), layers);
  const std::vector<tritrace::ExrAttribute> halton = {{"tritrace.sampler", std::string("halton")}};
  tritrace::write_exr(in[0], (work_ / "halton.exr").string(),
                      {in[1], in[2], in[3], in[4], tritrace::Image()},
                      tritrace::ExrPixelType::kFloat, halton);
  ExpectErrorLine(Run({"denoise", "halton.exr", "-o", "h.pfm"}), 1, "halton.exr",
                  "attribute tritrace.sampler is 'halton', not a sampler (sobol or independent)");
}

// An EXR of `side` x `side` pixels whose channels hold the values `fill` gives each.
void WriteExr(const fs::path& path, int side,
              const std::vector<std::pair<std::string, float (*)(int, int)>>& channels) {
  Imf::Header header(side, side);
  std::vector<std::vector<float>> planes;
  for (const auto& [name, fill] : channels) {
    header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    planes.emplace_back(static_cast<size_t>(side) * side);
    for (int y = 0; y < side; ++y) {
      for (int x = 0; x < side; ++x) planes.back()[static_cast<size_t>(y) * side + x] = fill(x, y);
    }
  }
  Imf::FrameBuffer frame;
  for (size_t c = 0; c < channels.size(); ++c) {
    frame.insert(channels[c].first,
                 Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes[c].data()), sizeof(float),
                            sizeof(float) * side));
  }
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(frame);
  file.writePixels(side);
}

float Checker(int x, int y) {
  return ((x / 3 + y / 3) % 2) != 0 ? 0.25f : 0.75f;
}
float Half(int, int) {
  return 0.5f;
}
float Zero(int, int) {
  return 0.0f;
}
float One(int, int) {
  return 1.0f;
}

TEST_F(CliTest, DenoiseReadsTheVarianceLayer) {
  // Zero variance says every difference is real: the checker stays as it is. Without the layer,
  // the variance estimated from the image is large, and the checker blurs.
  std::vector<std::pair<std::string, float (*)(int, int)>> channels = {
      {"R", Checker},     {"G", Checker},     {"B", Checker},     {"albedo.R", Half},
      {"albedo.G", Half}, {"albedo.B", Half}, {"normal.X", Zero}, {"normal.Y", Zero},
      {"normal.Z", One},  {"Z", One}};
  WriteExr(work_ / "plain.exr", 24, channels);
  for (const char* name : {"variance.R", "variance.G", "variance.B"})
    channels.push_back({name, Zero});
  WriteExr(work_ / "exact.exr", 24, channels);
  for (const char* in : {"plain", "exact"}) {
    const RunResult r =
        Run({"denoise", std::string(in) + ".exr", "-o", std::string(in) + "_out.exr", "-q"});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out + r.err, "");
  }
  const auto exact = tritrace::testing::read_exr_channels((work_ / "exact_out.exr").string());
  const auto plain = tritrace::testing::read_exr_channels((work_ / "plain_out.exr").string());
  double exact_error = 0.0, plain_error = 0.0;
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      const size_t i = static_cast<size_t>(y) * 24 + x;
      exact_error =
          std::max<double>(exact_error, std::abs(exact.channels.at("R").values[i] - Checker(x, y)));
      plain_error =
          std::max<double>(plain_error, std::abs(plain.channels.at("R").values[i] - Checker(x, y)));
    }
  }
  EXPECT_LT(exact_error, 1e-6);
  EXPECT_GT(plain_error, 0.01);
}

TEST_F(CliTest, DenoiseNamesTheFileAndTheMissingLayer) {
  RenderQuietly({"--scene", "cornell-area", "--width", "16", "--height", "16", "--spp", "1",
                 "--aovs", "albedo,depth"},
                "in.exr");
  ExpectErrorLine(Run({"denoise", "in.exr", "-o", "out.exr"}), 1, "in.exr",
                  "has no normal layer (normal.X, .Y, .Z)");
  ExpectErrorLine(Run({"denoise", "none.exr", "-o", "out.exr"}), 1, "none.exr", "no such file");
  WriteExr(work_ / "partial.exr", 4, {{"R", Half}, {"G", Half}, {"B", Half}, {"albedo.R", Half}});
  ExpectErrorLine(Run({"denoise", "partial.exr", "-o", "out.exr"}), 1, "partial.exr",
                  "has channel albedo.R but not albedo.G");
  ExpectErrorLine(Run({"denoise", "in.exr", "-o", "out.txt"}), 2, "--output", "unknown extension");
  ExpectOnlyFiles(work_, {"in.exr", "partial.exr"});
}

// pbrt-v4 scene files: render takes the film's size and file name, and each kind of thing it
// cannot render is one warning line naming where it first appears.
TEST_F(CliTest, PbrtFileRendersWithItsFilmAndWarnsOncePerKind) {
  std::ofstream(work_ / "scene.pbrt")
      << "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n"
         "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 6 "
         "\"string filename\" \"out.png\"\n"
         "Sampler \"independent\" \"integer pixelsamples\" 2\nWorldBegin\n"
         "LightSource \"point\" \"rgb I\" [10 10 10] \"point3 from\" [0 0 2]\n"
         "Shape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 0 0 3 0 0]\n"
         "Shape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 0 0 3 0 0]\n"
         "Shape \"sphere\"\n";
  const RunResult r = Run({"render", "scene.pbrt"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("tritrace: scene.pbrt:7: warning: Shape \"curve\" not supported: skipped "
                       "(2 times)\n"),
            std::string::npos)
      << r.err;
  ExpectRgb8Image(work_ / "out.png", 8, 6);
  const RunResult info = Run({"info", "scene.pbrt"});
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("camera: 8x6 at (0, 0, 5)"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("integrator: path, 2 spp, max depth 5"), std::string::npos) << info.out;
}

TEST_F(CliTest, PbrtErrorsNameFileLineAndColumn) {
  std::ofstream(work_ / "bad.pbrt") << "WorldBegin\n  Frobnicate 1\n";
  ExpectErrorLine(Run({"render", "bad.pbrt"}), 1, "bad.pbrt:2:3", "unknown directive 'Frobnicate'");
  std::ofstream(work_ / "cut.pbrt") << "WorldBegin\nShape \"sphere\" \"float radius\" [1";
  ExpectErrorLine(Run({"info", "cut.pbrt"}), 1, "cut.pbrt:2:31", "unterminated '['");
}

}  // namespace
