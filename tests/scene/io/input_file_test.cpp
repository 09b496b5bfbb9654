// MappedFile, how mesh files are read: the bytes read_input_file reads (the oracle, with read()),
// and the same one-line reason for each kind of file it refuses.
#include "tritrace/scene/io/input_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include "tritrace/error.h"

namespace tritrace {
namespace {

namespace fs = std::filesystem;

class InputFile : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tritrace_input_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p.string();
  }
  fs::path dir_;
};

std::string mapped_error(const std::string& path) {
  try {
    const MappedFile file(path);
  } catch (const Error& e) {
    EXPECT_EQ(e.subject(), path);
    return e.reason();
  }
  ADD_FAILURE() << "no error for " << path;
  return "";
}

TEST_F(InputFile, MapsTheBytesReadingGives) {
  std::string bytes;
  for (int i = 0; i < 100'000; ++i) bytes += static_cast<char>(i * 7 + i / 251);
  const std::string path = write("mesh.ply", bytes);
  MappedFile file(path);
  EXPECT_EQ(std::string(file.bytes().data(), file.bytes().size()), read_input_file(path));
  const MappedFile moved(std::move(file));
  EXPECT_TRUE(file.bytes().empty());
  EXPECT_EQ(std::string(moved.bytes().data(), moved.bytes().size()), bytes);
}

TEST_F(InputFile, RefusesWhatReadingRefusesWithTheSameReason) {
  const std::string empty = write("empty.ply", "");
  for (const std::string& path :
       {(dir_ / "missing.ply").string(), dir_.string(), empty, std::string("/dev/null")}) {
    std::string reason;
    try {
      read_input_file(path);
    } catch (const Error& e) {
      reason = e.reason();
    }
    EXPECT_FALSE(reason.empty()) << path;
    EXPECT_EQ(mapped_error(path), reason) << path;
  }
  EXPECT_EQ(mapped_error(empty), "is empty");
  EXPECT_EQ(mapped_error(dir_.string()), "is a folder, not a file");
}

}  // namespace
}  // namespace tritrace
