// ExrMemoryStream: an OpenEXR output stream into a growing byte vector, so that EXR files are
// encoded in memory and written atomically (image/atomic_file.h). Used by the image writer and by
// the partial films of distributed renders.
#pragma once

#include <ImfIO.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
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

}  // namespace tritrace
