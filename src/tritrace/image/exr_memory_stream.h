// ExrMemoryStream: an OpenEXR output stream into a growing byte vector, so that EXR files are
// encoded in memory and written atomically (image/atomic_file.h). Used by the image writer and by
// the partial films of distributed renders. ExrMemoryInputStream reads a file's bytes already in
// memory, as the EXR reader and its fuzz target do.
#pragma once

#include <ImfIO.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

namespace tritrace {

// OpenEXR seeks back to fill in the table of scanline offsets once the pixels are written, so
// writes may land inside what is already there.
class ExrMemoryStream final : public Imf::OStream {
 public:
  ExrMemoryStream() : Imf::OStream("(in memory)") {}

  void write(const char c[], int n) override {
    const size_t end = pos_ + static_cast<size_t>(n);
    if (end > bytes_.size()) bytes_.resize(end);
    std::memcpy(bytes_.data() + pos_, c, static_cast<size_t>(n));
    pos_ = end;
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = static_cast<size_t>(pos); }

  std::vector<uint8_t> take() { return std::move(bytes_); }

 private:
  std::vector<uint8_t> bytes_;
  size_t pos_ = 0;
};

// Reading past the end throws, as OpenEXR's file stream does at a truncated file.
class ExrMemoryInputStream final : public Imf::IStream {
 public:
  explicit ExrMemoryInputStream(std::span<const uint8_t> bytes, const char* name = "(in memory)")
      : Imf::IStream(name), bytes_(bytes) {}

  bool read(char c[], int n) override {
    if (n < 0 || pos_ > bytes_.size() || static_cast<uint64_t>(n) > bytes_.size() - pos_) {
      throw std::runtime_error("unexpected end of file");
    }
    std::memcpy(c, bytes_.data() + pos_, static_cast<size_t>(n));
    pos_ += static_cast<size_t>(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = pos; }

 private:
  std::span<const uint8_t> bytes_;
  uint64_t pos_ = 0;
};

}  // namespace tritrace
