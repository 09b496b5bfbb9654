// Texture lookups and decoding; stb_image does the file formats.
#include "tritrace/image/texture.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>

#include "stb_image.h"
#include "tritrace/error.h"
#include "tritrace/image/image_limits.h"

namespace tritrace {
namespace {

// Texel index i wrapped into [0, n).
int64_t wrap(int64_t i, int64_t n, WrapMode mode) {
  switch (mode) {
    case WrapMode::kClamp:
      return std::clamp<int64_t>(i, 0, n - 1);
    case WrapMode::kMirror: {
      const int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
      return m < n ? m : 2 * n - 1 - m;
    }
    case WrapMode::kRepeat:
      break;
  }
  return ((i % n) + n) % n;
}

// The texel coordinate, in texel units with texel centres at integers, of a texture coordinate;
// bounded so that far-away and non-finite coordinates still give an index (wrapped or clamped).
double texel_coordinate(float c, int n) {
  const double x = static_cast<double>(c) * n - 0.5;
  if (!std::isfinite(x)) return x > 0 ? 1e15 : -1e15;
  return std::clamp(x, -1e15, 1e15);
}

}  // namespace

float srgb_to_linear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

Texture::Texture(int width, int height, std::vector<glm::vec3> texels)
    : width_(width), height_(height), texels_(std::move(texels)) {}

Texture Texture::from_srgb8(const TextureImage& image) {
  std::array<float, 256> linear{};
  for (int b = 0; b < 256; ++b) linear[static_cast<size_t>(b)] = srgb_to_linear(b / 255.0f);
  std::vector<glm::vec3> texels(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < texels.size(); ++i) {
    texels[i] = {linear[image.rgb[3 * i]], linear[image.rgb[3 * i + 1]],
                 linear[image.rgb[3 * i + 2]]};
  }
  Texture texture(image.width, image.height, std::move(texels));
  if (!image.alpha.empty()) {
    std::vector<float> alpha(image.alpha.size());
    for (size_t i = 0; i < alpha.size(); ++i) alpha[i] = image.alpha[i] / 255.0f;
    texture.set_alpha(std::move(alpha));
  }
  return texture;
}

Texture Texture::checkerboard(const Checkerboard& board) {
  Texture texture(1, 1, {0.5f * (board.even + board.odd)});
  texture.checker_ = board;
  return texture;
}

Texture Texture::mapped(glm::vec3 scale, glm::vec3 offset) const {
  Texture out = *this;
  for (glm::vec3& t : out.texels_) t = scale * t + offset;
  if (out.checker_) {
    out.checker_->even = scale * out.checker_->even + offset;
    out.checker_->odd = scale * out.checker_->odd + offset;
  }
  return out;
}

Texture Texture::from_linear8(const TextureImage& image) {
  std::vector<glm::vec3> texels(static_cast<size_t>(image.width) * image.height);
  for (size_t i = 0; i < texels.size(); ++i) {
    texels[i] = glm::vec3(image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]) / 255.0f;
  }
  return Texture(image.width, image.height, std::move(texels));
}

Texture::Footprint Texture::footprint(glm::vec2 uv, WrapMode s, WrapMode t) const {
  const double x = texel_coordinate(uv.x, width_);
  const double y = texel_coordinate(1.0f - uv.y, height_);
  const double x0 = std::floor(x), y0 = std::floor(y);
  const int64_t ix = static_cast<int64_t>(x0), iy = static_cast<int64_t>(y0);
  return {static_cast<size_t>(wrap(ix, width_, s)),
          static_cast<size_t>(wrap(ix + 1, width_, s)),
          static_cast<size_t>(wrap(iy, height_, t)),
          static_cast<size_t>(wrap(iy + 1, height_, t)),
          static_cast<float>(x - x0),
          static_cast<float>(y - y0)};
}

glm::vec3 Texture::lookup(glm::vec2 uv, WrapMode s, WrapMode t) const {
  if (checker_) {
    // In double, so that far-away coordinates still floor exactly; a non-finite one is odd.
    const double fs = std::floor(static_cast<double>(checker_->scale.x) * uv.x + checker_->delta.x);
    const double ft = std::floor(static_cast<double>(checker_->scale.y) * uv.y + checker_->delta.y);
    return std::fmod(std::abs(fs + ft), 2.0) == 0.0 ? checker_->even : checker_->odd;
  }
  const Footprint f = footprint(uv, s, t);
  const auto at = [&](size_t x, size_t y) -> const glm::vec3& {
    return texels_[y * static_cast<size_t>(width_) + x];
  };
  const glm::vec3 top = (1.0f - f.fx) * at(f.x_lo, f.y_lo) + f.fx * at(f.x_hi, f.y_lo);
  const glm::vec3 bottom = (1.0f - f.fx) * at(f.x_lo, f.y_hi) + f.fx * at(f.x_hi, f.y_hi);
  return (1.0f - f.fy) * top + f.fy * bottom;
}

float Texture::alpha(glm::vec2 uv, WrapMode s, WrapMode t) const {
  if (alpha_.empty()) return 1.0f;
  const Footprint f = footprint(uv, s, t);
  const auto at = [&](size_t x, size_t y) { return alpha_[y * static_cast<size_t>(width_) + x]; };
  const float top = (1.0f - f.fx) * at(f.x_lo, f.y_lo) + f.fx * at(f.x_hi, f.y_lo);
  const float bottom = (1.0f - f.fx) * at(f.x_lo, f.y_hi) + f.fx * at(f.x_hi, f.y_hi);
  return (1.0f - f.fy) * top + f.fy * bottom;
}

void drop_opaque_alpha(TextureImage& image) {
  if (std::all_of(image.alpha.begin(), image.alpha.end(), [](uint8_t a) { return a == 255; })) {
    image.alpha.clear();
  }
}

TextureImage decode_texture_image(std::span<const uint8_t> bytes, const std::string& subject) {
  if (bytes.empty()) throw Error(subject, "cannot read texture: the file is empty");
  if (bytes.size() > static_cast<size_t>(INT_MAX)) {
    throw Error(subject, "cannot read texture: the file is too large");
  }
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &channels)) {
    throw Error(subject, std::string("cannot read texture: ") + stbi_failure_reason());
  }
  try {
    check_image_sides(w, h, subject);
    check_file_holds_pixels(w, h, least_bytes_for_pixels(w, h), bytes.size(), subject);
  } catch (const Error& e) {
    throw Error(subject, "cannot read texture: " + e.reason());
  }
  // Grey + alpha and RGBA files keep their alpha channel.
  const bool has_alpha = channels == 2 || channels == 4;
  const int wanted = has_alpha ? 4 : 3;
  uint8_t* data = stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h,
                                        &channels, wanted);
  if (!data) throw Error(subject, std::string("cannot read texture: ") + stbi_failure_reason());
  const size_t texels = static_cast<size_t>(w) * static_cast<size_t>(h);
  TextureImage image{w, h, {}, {}};
  if (has_alpha) {
    image.rgb.resize(texels * 3);
    image.alpha.resize(texels);
    for (size_t i = 0; i < texels; ++i) {
      for (size_t c = 0; c < 3; ++c) image.rgb[3 * i + c] = data[4 * i + c];
      image.alpha[i] = data[4 * i + 3];
    }
    drop_opaque_alpha(image);
  } else {
    image.rgb.assign(data, data + texels * 3);
  }
  stbi_image_free(data);
  return image;
}

}  // namespace tritrace
