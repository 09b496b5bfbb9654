// Textures: images looked up by texture coordinates (linear RGB texels, bilinear filtering, the
// repeat / clamp / mirror wrap modes of OpenGL and glTF samplers) or pbrt-v4's procedural
// checkerboard, and the sRGB decoding of the 8-bit images that colour textures are stored as.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tritrace {

enum class WrapMode : uint8_t { kRepeat, kClamp, kMirror };

// An 8-bit RGB image as decoded from its file, row 0 the top of the picture: what the mesh
// importer's process hands back (textures are decoded there, beside the parser).
struct TextureImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  // width * height * 3 bytes
  // width * height bytes of coverage (0 transparent, 255 opaque), or empty where the image has
  // no alpha channel or every texel is opaque.
  std::vector<uint8_t> alpha;
  // Colour (sRGB-encoded, decoded to linear when loaded) or data stored as it is (glTF's
  // metallic-roughness, normal and transmission textures).
  bool srgb = true;
};

// pbrt-v4's two-dimensional checkerboard texture with its uv mapping: with s = scale.x u + delta.x
// and t = scale.y v + delta.y, the colour `even` where floor(s) + floor(t) is even and `odd`
// elsewhere (pbrt's tex1 and tex2). Evaluated at the point; pbrt filters it over the pixel's
// footprint, which many samples per pixel average to the same.
struct Checkerboard {
  glm::vec2 scale{1.0f};
  glm::vec2 delta{0.0f};
  glm::vec3 even{1.0f};
  glm::vec3 odd{0.0f};
};

// The IEC 61966-2-1 sRGB transfer curve, encoded [0, 1] to linear [0, 1].
float srgb_to_linear(float encoded);

class Texture {
 public:
  Texture() = default;
  // `texels` row by row from the top, width * height of them; width, height >= 1.
  Texture(int width, int height, std::vector<glm::vec3> texels);
  // An 8-bit colour image: each byte b decoded as srgb_to_linear(b / 255); its alpha bytes, when
  // it has them, as b / 255 (alpha is linear).
  static Texture from_srgb8(const TextureImage& image);
  // A procedural checkerboard, exact at every uv (no texels, no filtering; the wrap modes do not
  // apply): one texel, the mean of its two colours, stands for it where texels are read.
  static Texture checkerboard(const Checkerboard& board);
  // The checkerboard this texture is, or nullopt for an image.
  const std::optional<Checkerboard>& checker() const { return checker_; }
  // The texture whose every texel (and checkerboard colour) is scale * c + offset, alpha kept: the
  // lookup of the result is scale * lookup + offset exactly, as bilinear weights sum to 1.
  Texture mapped(glm::vec3 scale, glm::vec3 offset) const;
  // An 8-bit data image: each byte b read as b / 255.
  static Texture from_linear8(const TextureImage& image);
  // from_srgb8 or from_linear8, as image.srgb says.
  static Texture from_image(const TextureImage& image) {
    return image.srgb ? from_srgb8(image) : from_linear8(image);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  const glm::vec3& texel(int x, int y) const {
    return texels_[static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)];
  }
  const std::vector<glm::vec3>& texels() const { return texels_; }

  // Bilinear filtering (or the checkerboard's value) at texture coordinates uv, with OpenGL's
  // convention (also assimp's, which flips glTF's v on import): u = 0 is the left edge, v = 0 the
  // bottom edge, so texel (x, y) has its centre at ((x + 0.5) / width, 1 - (y + 0.5) / height). `s`
  // wraps u, `t` wraps v.
  glm::vec3 lookup(glm::vec2 uv, WrapMode s, WrapMode t) const;

  // Whether the texture has an alpha channel (one texel below 1).
  bool has_alpha() const { return !alpha_.empty(); }
  // The alpha channel at uv, filtered as lookup filters colour; 1 without a channel.
  float alpha(glm::vec2 uv, WrapMode s, WrapMode t) const;
  const std::vector<float>& alpha_texels() const { return alpha_; }
  // Gives the texture an alpha channel: width * height values in [0, 1], row by row from the top.
  void set_alpha(std::vector<float> alpha) { alpha_ = std::move(alpha); }

 private:
  // The texels bilinear filtering at uv blends (columns x_lo, x_hi, rows y_lo, y_hi, wrapped) and
  // the fractions fx, fy of the way from the low to the high ones.
  struct Footprint {
    size_t x_lo, x_hi, y_lo, y_hi;
    float fx, fy;
  };
  Footprint footprint(glm::vec2 uv, WrapMode s, WrapMode t) const;

  int width_ = 0;
  int height_ = 0;
  std::vector<glm::vec3> texels_;
  std::vector<float> alpha_;  // empty: opaque
  std::optional<Checkerboard> checker_;
};

// Empties image.alpha when every byte of it is 255 (an opaque image needs no alpha test).
void drop_opaque_alpha(TextureImage& image);

// Decodes an image file's bytes (PNG, JPEG, BMP, TGA ... through stb_image) to 8-bit RGB. Throws
// Error(subject, "cannot read texture: <reason>") for bytes it cannot decode, a side longer than
// kMaxImageSide, a header whose pixels the bytes are too few to hold (image/image_limits.h; both
// checked before decoding).
TextureImage decode_texture_image(std::span<const uint8_t> bytes, const std::string& subject);

}  // namespace tritrace
