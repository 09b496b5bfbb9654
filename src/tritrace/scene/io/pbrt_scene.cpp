// The pbrt-v4 interpreter: reads directives with their parameter lists, keeps pbrt's graphics state
// (current transform, material, area light, reverse orientation, named coordinate systems,
// attribute stack, object definitions) and turns cameras, shapes, materials, textures and lights
// into a LoadedScene. Conventions that matter for the picture: pbrt's camera space is x right,
// y up, z forward, so the image's x axis is the camera's +x (LookAt's cross(up, dir)), which is a
// mirror of what tritrace's right-handed Camera::look_at builds (CameraSpec::mirror_x records it);
// the field of view applies to the image's shorter axis.
#include "tritrace/scene/io/pbrt_scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <utility>

#include "tritrace/error.h"
#include "tritrace/image/image_io.h"
#include "tritrace/scene/io/input_file.h"
#include "tritrace/scene/io/pbrt_params.h"
#include "tritrace/scene/io/pbrt_shapes.h"
#include "tritrace/scene/io/pbrt_tokenizer.h"
#include "tritrace/scene/io/triangle_filter.h"

namespace tritrace {
namespace fs = std::filesystem;

bool is_pbrt_file(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return ext == ".pbrt";
}

namespace {

// pbrt's defaults where they differ from tritrace's (pbrt-v4's Film, Sampler and Integrator).
constexpr int kPbrtWidth = 1280, kPbrtHeight = 720;
constexpr uint32_t kPbrtSpp = 16;
constexpr int kPbrtMaxDepth = 5;
constexpr double kPbrtFov = 90.0;
// pbrt-v4's default focaldistance (cameras.cpp): far enough that a lens focuses at infinity.
constexpr double kPbrtFocalDistance = 1e6;
constexpr float kMaxIndex = 10.0f;  // the scene file's range for ior and eta
constexpr int kMaxIncludeDepth = 32;
// The texels that mix textures may bake in all (each bake copies an image): a file chaining mixes
// of a large image cannot exhaust memory; beyond it a mix takes the side of larger weight.
constexpr size_t kMaxBakedTexels = size_t{1} << 26;

using dmat4 = glm::dmat4;
using dvec3 = glm::dvec3;

// Where corners, normals and texture coordinates of drawn triangles collect (world space, or an
// object definition's space), with one material per triangle. Normals and uvs are kept for every
// triangle once any shape has them (zeros elsewhere: add_checked gives those triangles their
// geometric normal).
struct Soup {
  std::vector<glm::vec3> corners;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec2> uvs;
  std::vector<uint32_t> material;
  bool has_normals = false;
  bool has_uvs = false;

  void add(const glm::vec3 p[3], const glm::vec3* n, const glm::vec2* uv, uint32_t m) {
    const size_t before = corners.size();
    corners.insert(corners.end(), p, p + 3);
    if (n && !has_normals) {
      normals.assign(before, glm::vec3(0.0f));
      has_normals = true;
    }
    if (uv && !has_uvs) {
      uvs.assign(before, glm::vec2(0.0f));
      has_uvs = true;
    }
    if (has_normals) {
      for (int k = 0; k < 3; ++k) normals.push_back(n ? n[k] : glm::vec3(0.0f));
    }
    if (has_uvs) {
      for (int k = 0; k < 3; ++k) uvs.push_back(uv ? uv[k] : glm::vec2(0.0f));
    }
    material.push_back(m);
  }
};

// p -> M p with M's linear part for normals (inverse transpose) and whether M mirrors.
struct Placement {
  dmat4 m{1.0};
  glm::dmat3 normal{1.0};
  bool mirrors = false;

  explicit Placement(const dmat4& matrix) : m(matrix) {
    const glm::dmat3 linear(matrix);
    const double det = glm::determinant(linear);
    mirrors = det < 0.0;
    if (det != 0.0 && std::isfinite(det)) normal = glm::transpose(glm::inverse(linear));
  }
  glm::vec3 point(glm::vec3 p) const { return glm::vec3(m * glm::dvec4(dvec3(p), 1.0)); }
  glm::vec3 direction(glm::vec3 n) const {
    const dvec3 w = normal * dvec3(n);
    const double len = glm::length(w);
    return len > 0.0 ? glm::vec3(w / len) : glm::vec3(0.0f);
  }
};

// The part of the graphics state that AttributeBegin saves.
struct GraphicsState {
  dmat4 ctm{1.0};
  bool reverse = false;
  int material = -1;  // into the scene's materials; -1: pbrt's default (diffuse 0.5)
  std::optional<glm::vec3> area_emission;
  bool area_two_sided = false;
};

// A spectrum texture as tritrace can use it: an image (with a factor) or a constant colour.
struct SpectrumTexture {
  int32_t image = -1;  // into scene.textures
  glm::vec3 factor{1.0f};
  // An imagemap's uv mapping, (u, v) -> (uscale u + udelta, vscale v + vdelta), applied before the
  // lookup (TextureRef::transform).
  glm::vec2 scale{1.0f};
  glm::vec2 delta{0.0f};
  bool same_lookup(const SpectrumTexture& o) const {
    return image == o.image && scale == o.scale && delta == o.delta;
  }
};

struct Warning {
  std::string where;
  std::string what;
  size_t count = 0;
};

class Interpreter {
 public:
  Interpreter(const std::string& path, const PbrtOptions& options)
      : options_(options), path_(path), main_dir_(fs::path(path).parent_path()) {
    out_.integrator.kind = IntegratorSpec::Kind::kPath;
    out_.integrator.spp = kPbrtSpp;
    out_.integrator.max_depth = kPbrtMaxDepth;
    out_.camera.width = kPbrtWidth;
    out_.camera.height = kPbrtHeight;
  }

  LoadedScene run(std::string_view text, const std::string& path) {
    parse(std::string(text), path, 0);
    finish();
    return std::move(out_);
  }

 private:
  // --- reading -------------------------------------------------------------------------------

  [[noreturn]] static void fail(const PbrtLocation& at, const std::string& reason) {
    throw Error(at.describe(), reason);
  }

  void warn(const PbrtLocation& at, const std::string& what) {
    for (Warning& w : warnings_) {
      if (w.what == what) {
        ++w.count;
        return;
      }
    }
    warnings_.push_back({at.describe_line(), what, 1});
  }

  void warn_unused(const PbrtParams& params, const std::string& directive) {
    for (const PbrtParam* p : params.unused()) {
      warn(p->at, "parameter \"" + p->type + " " + p->name + "\" of " + directive + " ignored");
    }
  }

  PbrtToken expect(PbrtTokenizer& t, const PbrtToken& directive, const char* what) {
    std::optional<PbrtToken> next = t.next();
    if (!next) {
      fail(t.end_location(),
           "unexpected end of file: " + directive.text + " needs " + std::string(what));
    }
    return *next;
  }

  std::string read_string(PbrtTokenizer& t, const PbrtToken& directive) {
    const PbrtToken s = expect(t, directive, "a quoted string");
    if (s.kind != PbrtToken::Kind::kString) {
      fail(s.at, directive.text + " needs a quoted string, got " + shown_token(s));
    }
    return s.text;
  }

  double read_number(PbrtTokenizer& t, const PbrtToken& directive) {
    const PbrtToken s = expect(t, directive, "a number");
    if (s.kind == PbrtToken::Kind::kWord) {
      // The parameter parser's number rules, through a one-value list.
      PbrtTokenizer one("\"float x\" " + s.text, *s.at.file);
      try {
        const PbrtParams p = parse_pbrt_params(one);
        if (p.list.size() == 1 && p.list[0].numbers.size() == 1) return p.list[0].numbers[0];
      } catch (const Error&) {
      }
    }
    fail(s.at, directive.text + " needs a number, got " + shown_token(s));
  }

  // n numbers, optionally between brackets (Transform [ ... ] or Transform ...).
  std::vector<double> read_numbers(PbrtTokenizer& t, const PbrtToken& directive, size_t n) {
    const bool bracket = t.peek() && t.peek()->kind == PbrtToken::Kind::kOpen;
    if (bracket) t.next();
    std::vector<double> v;
    for (size_t i = 0; i < n; ++i) v.push_back(read_number(t, directive));
    if (bracket) {
      const PbrtToken close = expect(t, directive, "']'");
      if (close.kind != PbrtToken::Kind::kClose) {
        fail(close.at, directive.text + " takes " + std::to_string(n) +
                           " numbers; expected ']', got " + shown_token(close));
      }
    }
    return v;
  }

  // A file named in the scene: relative to the naming file's folder, else to the main file's.
  std::string resolve(const std::string& name, const PbrtLocation& at) const {
    const fs::path p(name);
    if (p.is_absolute()) return name;
    const fs::path local = fs::path(*at.file).parent_path() / p;
    if (fs::exists(local)) return local.lexically_normal().string();
    return (main_dir_ / p).lexically_normal().string();
  }

  void parse(std::string text, const std::string& path, int depth) {
    PbrtTokenizer t(std::move(text), path);
    while (std::optional<PbrtToken> d = t.next()) directive(t, *d, depth);
  }

  void include(const std::string& name, const PbrtToken& d, int depth) {
    if (depth >= kMaxIncludeDepth) {
      fail(d.at, d.text + " nested more than " + std::to_string(kMaxIncludeDepth) +
                     " deep (does a file include itself?)");
    }
    const std::string file = resolve(name, d.at);
    std::string text;
    try {
      text = options_.read_text ? options_.read_text(file) : read_input_file(file);
    } catch (const Error& e) {
      fail(d.at, d.text + " \"" + name + "\": " + e.reason());
    }
    parse(std::move(text), file, depth + 1);
  }

  // --- directives ----------------------------------------------------------------------------

  void directive(PbrtTokenizer& t, const PbrtToken& d, int depth) {
    if (d.kind != PbrtToken::Kind::kWord) {
      fail(d.at, "expected a directive, got " + shown_token(d));
    }
    const std::string& name = d.text;
    auto params = [&] { return parse_pbrt_params(t); };
    if (name == "Include" || name == "Import") {
      include(read_string(t, d), d, depth);
    } else if (name == "Identity") {
      gs_.ctm = dmat4(1.0);
    } else if (name == "Translate") {
      const auto v = read_numbers(t, d, 3);
      gs_.ctm = gs_.ctm * translate(dvec3(v[0], v[1], v[2]));
    } else if (name == "Scale") {
      const auto v = read_numbers(t, d, 3);
      dmat4 s(1.0);
      s[0][0] = v[0];
      s[1][1] = v[1];
      s[2][2] = v[2];
      gs_.ctm = gs_.ctm * s;
    } else if (name == "Rotate") {
      const auto v = read_numbers(t, d, 4);
      const dvec3 axis(v[1], v[2], v[3]);
      if (!(glm::length(axis) > 0.0)) fail(d.at, "Rotate needs a non-zero axis");
      gs_.ctm = gs_.ctm * rotate(v[0], glm::normalize(axis));
    } else if (name == "LookAt") {
      const auto v = read_numbers(t, d, 9);
      gs_.ctm = gs_.ctm * look_at(dvec3(v[0], v[1], v[2]), dvec3(v[3], v[4], v[5]),
                                  dvec3(v[6], v[7], v[8]), d.at);
    } else if (name == "Transform" || name == "ConcatTransform") {
      // pbrt lists the matrix column by column (the translation is in values 12 to 14).
      const auto v = read_numbers(t, d, 16);
      dmat4 m;
      for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) m[c][r] = v[static_cast<size_t>(4 * c + r)];
      }
      gs_.ctm = name == "Transform" ? m : gs_.ctm * m;
    } else if (name == "CoordinateSystem") {
      named_spaces_[read_string(t, d)] = gs_.ctm;
    } else if (name == "CoordSysTransform") {
      const std::string space = read_string(t, d);
      const auto it = named_spaces_.find(space);
      if (it == named_spaces_.end()) {
        warn(d.at, "CoordSysTransform to an unknown coordinate system ignored");
      } else {
        gs_.ctm = it->second;
      }
    } else if (name == "ReverseOrientation") {
      gs_.reverse = !gs_.reverse;
    } else if (name == "AttributeBegin" || name == "TransformBegin") {
      stack_.push_back({gs_, name == "TransformBegin", d.at});
    } else if (name == "AttributeEnd" || name == "TransformEnd") {
      if (stack_.empty()) fail(d.at, name + " without a matching begin");
      if (stack_.back().transform_only != (name == "TransformEnd")) {
        fail(d.at, name + " closes the " +
                       (stack_.back().transform_only ? "TransformBegin" : "AttributeBegin") +
                       " at " + stack_.back().at.describe());
      }
      if (stack_.back().transform_only) {
        gs_.ctm = stack_.back().state.ctm;
      } else {
        gs_ = stack_.back().state;
      }
      stack_.pop_back();
    } else if (name == "ActiveTransform") {
      const PbrtToken which = expect(t, d, "StartTime, EndTime or All");
      if (which.text != "StartTime" && which.text != "EndTime" && which.text != "All") {
        fail(which.at,
             "ActiveTransform takes StartTime, EndTime or All, got " + shown_token(which));
      }
      if (which.text != "All")
        warn(d.at, "ActiveTransform (motion blur) ignored: transforms apply at all times");
    } else if (name == "TransformTimes") {
      read_numbers(t, d, 2);
      warn(d.at, "TransformTimes (motion blur) ignored");
    } else if (name == "WorldBegin") {
      if (in_world_) fail(d.at, "a second WorldBegin");
      in_world_ = true;
      gs_.ctm = dmat4(1.0);
      named_spaces_["world"] = gs_.ctm;
    } else if (name == "WorldEnd") {
      // pbrt-v3's end of the scene; pbrt-v4 ends it at the end of the file.
    } else if (name == "Camera") {
      const std::string type = read_string(t, d);
      camera(type, params(), d);
    } else if (name == "Film") {
      const std::string type = read_string(t, d);
      film(type, params(), d);
    } else if (name == "Sampler") {
      const std::string type = read_string(t, d);
      sampler(type, params(), d);
    } else if (name == "Integrator") {
      const std::string type = read_string(t, d);
      integrator(type, params(), d);
    } else if (name == "ColorSpace") {
      // sRGB is what tritrace renders in; other spaces' colours are read as if sRGB.
      const std::string space = read_string(t, d);
      if (space != "srgb")
        warn(d.at, "ColorSpace \"" + space + "\" ignored: colours are read as sRGB");
    } else if (name == "PixelFilter" || name == "Accelerator" || name == "Option" ||
               name == "Attribute") {
      // Each takes a string (Option takes a parameter instead) and parameters.
      if (name != "Option") read_string(t, d);
      params();
      warn(d.at, name + " ignored (" +
                     (name == "PixelFilter" ? std::string("tritrace's --filter chooses the filter")
                                            : std::string("not supported")) +
                     ")");
    } else if (name == "MakeNamedMedium") {
      read_string(t, d);
      params();
      warn(d.at, "participating media (MakeNamedMedium) skipped");
    } else if (name == "MediumInterface") {
      read_string(t, d);
      if (t.peek() && t.peek()->kind == PbrtToken::Kind::kString) t.next();
      warn(d.at, "MediumInterface skipped (no participating media)");
    } else if (name == "Material") {
      const std::string type = read_string(t, d);
      gs_.material = static_cast<int>(material(type, params(), d));
    } else if (name == "MakeNamedMaterial") {
      const std::string material_name = read_string(t, d);
      const PbrtParams p = params();
      const std::string type = p.get_string("type", "");
      if (type.empty())
        fail(d.at, "MakeNamedMaterial \"" + material_name + "\" needs a \"string type\"");
      named_materials_[material_name] = material(type, p, d);
    } else if (name == "NamedMaterial") {
      const std::string material_name = read_string(t, d);
      const auto it = named_materials_.find(material_name);
      if (it == named_materials_.end()) {
        fail(d.at, "NamedMaterial \"" + material_name + "\" was not made by MakeNamedMaterial");
      }
      gs_.material = static_cast<int>(it->second);
    } else if (name == "Texture") {
      const std::string tex_name = read_string(t, d);
      const std::string type = read_string(t, d);
      const std::string cls = read_string(t, d);
      texture(tex_name, type, cls, params(), d);
    } else if (name == "LightSource") {
      const std::string type = read_string(t, d);
      light(type, params(), d);
    } else if (name == "AreaLightSource") {
      const std::string type = read_string(t, d);
      area_light(type, params(), d);
    } else if (name == "Shape") {
      const std::string type = read_string(t, d);
      shape(type, params(), d);
    } else if (name == "ObjectBegin") {
      const std::string object_name = read_string(t, d);
      if (object_)
        fail(d.at, "ObjectBegin inside the definition of object \"" + object_name_ + "\"");
      stack_.push_back({gs_, false, d.at});
      object_name_ = object_name;
      object_ = &objects_[object_name];
      *object_ = Soup{};
    } else if (name == "ObjectEnd") {
      if (!object_) fail(d.at, "ObjectEnd without ObjectBegin");
      object_ = nullptr;
      if (!stack_.empty()) {
        gs_ = stack_.back().state;
        stack_.pop_back();
      }
    } else if (name == "ObjectInstance") {
      const std::string object_name = read_string(t, d);
      const auto it = objects_.find(object_name);
      if (it == objects_.end())
        fail(d.at, "ObjectInstance of an undefined object \"" + object_name + "\"");
      if (object_) fail(d.at, "ObjectInstance inside an object definition");
      instance(object_name, it->second, gs_.ctm, d.at);
    } else {
      fail(d.at, "unknown directive " + shown_token(d));
    }
  }

  // --- transforms ----------------------------------------------------------------------------

  static dmat4 translate(dvec3 v) {
    dmat4 m(1.0);
    m[3] = glm::dvec4(v, 1.0);
    return m;
  }

  // Rotation by `degrees` about the unit `axis` (counter-clockwise looking down the axis, as
  // pbrt's Rotate and the right-hand rule have it).
  static dmat4 rotate(double degrees, dvec3 a) {
    const double th = degrees * std::numbers::pi / 180.0;
    const double c = std::cos(th), s = std::sin(th);
    dmat4 m(1.0);
    // Rodrigues' formula, written by columns (glm's m[column][row]).
    m[0] = glm::dvec4(a.x * a.x + (1 - a.x * a.x) * c, a.x * a.y * (1 - c) + a.z * s,
                      a.x * a.z * (1 - c) - a.y * s, 0.0);
    m[1] = glm::dvec4(a.x * a.y * (1 - c) - a.z * s, a.y * a.y + (1 - a.y * a.y) * c,
                      a.y * a.z * (1 - c) + a.x * s, 0.0);
    m[2] = glm::dvec4(a.x * a.z * (1 - c) + a.y * s, a.y * a.z * (1 - c) - a.x * s,
                      a.z * a.z + (1 - a.z * a.z) * c, 0.0);
    return m;
  }

  // pbrt's LookAt: the camera-from-world transform of a camera at `eye` looking at `target`,
  // whose +x is cross(up, dir) and +y the up direction made perpendicular to dir.
  dmat4 look_at(dvec3 eye, dvec3 target, dvec3 up, const PbrtLocation& at) {
    const dvec3 view = target - eye;
    if (!(glm::length(view) > 0.0)) fail(at, "LookAt's eye and target are the same point");
    const dvec3 dir = glm::normalize(view);
    const dvec3 side = glm::cross(glm::length(up) > 0.0 ? glm::normalize(up) : up, dir);
    if (!(glm::length(side) > 1e-12))
      fail(at, "LookAt's up vector is parallel to the view direction");
    const dvec3 right = glm::normalize(side);
    const dvec3 new_up = glm::cross(dir, right);
    dmat4 world_from_camera(1.0);
    world_from_camera[0] = glm::dvec4(right, 0.0);
    world_from_camera[1] = glm::dvec4(new_up, 0.0);
    world_from_camera[2] = glm::dvec4(dir, 0.0);
    world_from_camera[3] = glm::dvec4(eye, 1.0);
    return glm::inverse(world_from_camera);
  }

  // --- camera, film, sampler, integrator -----------------------------------------------------

  void camera(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    if (in_world_) fail(d.at, "Camera after WorldBegin");
    camera_from_world_ = gs_.ctm;
    camera_at_ = d.at;
    named_spaces_["camera"] = glm::inverse(gs_.ctm);
    orthographic_ = type == "orthographic";
    if (type != "perspective" && !orthographic_) {
      warn(d.at, "Camera \"" + type + "\" approximated by a perspective camera");
    }
    screen_half_height_.reset();
    const PbrtParam* window = p.find("screenwindow");
    if (window && !orthographic_) {
      warn(window->at, "screenwindow of a perspective camera ignored (fov sets the view)");
    } else if (window) {
      // [x0 x1 y0 y1] in screen space (camera space for the orthographic camera): tritrace's
      // cameras centre the image on the view axis and take their width from the film's aspect,
      // so only the window's height is kept.
      const auto& v = window->numbers;
      if (v.size() != 4 || !(v[3] > v[2]) || !(v[1] > v[0])) {
        fail(window->at,
             "\"float screenwindow\" takes four numbers x0 x1 y0 y1 with x0 < x1, y0 < y1");
      }
      if (v[0] != -v[1] || v[2] != -v[3]) {
        warn(window->at, "an off-centre screenwindow approximated by a centred one");
      }
      screen_half_height_ = (v[3] - v[2]) / 2.0;
    }
    fov_ = p.get_float("fov", kPbrtFov);
    if (!(fov_ > 0.0 && fov_ < 180.0))
      fail(d.at, "\"float fov\" must be between 0 and 180 degrees");
    lens_radius_ = p.get_float("lensradius", 0.0);
    focal_distance_ = p.get_float("focaldistance", kPbrtFocalDistance);
    if (!(lens_radius_ >= 0.0) || !std::isfinite(lens_radius_)) {
      fail(d.at, "\"float lensradius\" must be a finite number of at least 0");
    }
    if (!(focal_distance_ > 0.0) || !std::isfinite(focal_distance_)) {
      fail(d.at, "\"float focaldistance\" must be a finite number greater than 0");
    }
    warn_unused(p, "Camera");
  }

  void film(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    if (type != "rgb") warn(d.at, "Film \"" + type + "\" treated as \"rgb\"");
    const int w = p.get_int("xresolution", kPbrtWidth);
    const int h = p.get_int("yresolution", kPbrtHeight);
    if (w < 1 || w > kMaxImageSide || h < 1 || h > kMaxImageSide) {
      fail(d.at, "film resolution must be from 1 to " + std::to_string(kMaxImageSide) +
                     " pixels, got " + std::to_string(w) + "x" + std::to_string(h));
    }
    out_.camera.width = w;
    out_.camera.height = h;
    const std::string file = p.get_string("filename", "");
    if (!file.empty()) {
      if (image_format_for(file)) {
        out_.output = file;
      } else {
        warn(d.at, "Film filename \"" + file + "\" has an extension tritrace does not write (" +
                       std::string(kImageExtensions) + "); the default output is used");
      }
    }
    warn_unused(p, "Film");
  }

  void sampler(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    int64_t spp = p.get_int("pixelsamples", static_cast<int>(kPbrtSpp));
    if (type == "stratified") {
      spp = int64_t{p.get_int("xsamples", 4)} * p.get_int("ysamples", 4);
      p.find("jitter");
    }
    if (spp < 1 || spp > int64_t{kMaxSpp}) {
      fail(d.at, "pixel samples must be from 1 to " + std::to_string(kMaxSpp));
    }
    out_.integrator.spp = static_cast<uint32_t>(spp);
    out_.integrator.sampler =
        type == "independent" ? SamplerKind::kIndependent : SamplerKind::kSobol;
    if (type != "independent" && type != "sobol" && type != "zsobol" && type != "paddedsobol" &&
        type != "halton" && type != "pmj02bn" && type != "stratified") {
      warn(d.at, "Sampler \"" + type + "\" unknown; tritrace's Sobol sampler used");
    }
    p.find("seed");
    p.find("randomization");
    warn_unused(p, "Sampler");
  }

  void integrator(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    // volpath without media renders what path renders; bdpt is tritrace's bdpt.
    out_.integrator.kind =
        type == "bdpt" ? IntegratorSpec::Kind::kBdpt : IntegratorSpec::Kind::kPath;
    if (type != "path" && type != "volpath" && type != "bdpt") {
      warn(d.at, "Integrator \"" + type + "\" replaced by tritrace's path tracer");
    }
    // bdpt's debugging images.
    p.find("visualizestrategies");
    p.find("visualizeweights");
    const int depth = p.get_int("maxdepth", kPbrtMaxDepth);
    if (depth < 0 || depth > kMaxMaxDepth) {
      fail(d.at, "\"integer maxdepth\" must be from 0 to " + std::to_string(kMaxMaxDepth));
    }
    out_.integrator.max_depth = depth;
    p.find("regularize");
    p.find("lightsampler");
    warn_unused(p, "Integrator");
  }

  // --- textures and materials ----------------------------------------------------------------

  void texture(const std::string& name, const std::string& type, const std::string& cls,
               const PbrtParams& p, const PbrtToken& d) {
    if (type != "spectrum" && type != "float") {
      fail(d.at, "Texture type must be \"spectrum\" or \"float\", got \"" + type + "\"");
    }
    if (type == "float") {
      float_texture(name, cls, p, d);
      warn_unused(p, "Texture");
      return;
    }
    SpectrumTexture tex;
    if (cls == "imagemap") {
      tex.image = image_texture(p.get_string("filename", ""), p.get_string("encoding", ""), d);
      tex.factor = glm::vec3(static_cast<float>(p.get_float("scale", 1.0)));
      if (p.get_bool("invert", false)) warn(d.at, "imagemap \"invert\" ignored");
      for (const char* k : {"filter", "maxanisotropy", "wrap"}) p.find(k);
      const std::string mapping = p.get_string("mapping", "uv");
      if (mapping != "uv") warn(d.at, "texture mapping \"" + mapping + "\" replaced by \"uv\"");
      // pbrt-v4's UVMapping: st = (uscale u + udelta, vscale v + vdelta); its image lookup puts
      // t = 0 at the bottom of the image, as tritrace's textures do.
      tex.scale = glm::vec2(static_cast<float>(p.get_float("uscale", 1.0)),
                            static_cast<float>(p.get_float("vscale", 1.0)));
      tex.delta = glm::vec2(static_cast<float>(p.get_float("udelta", 0.0)),
                            static_cast<float>(p.get_float("vdelta", 0.0)));
    } else if (cls == "constant") {
      tex.factor = p.get_rgb("value").value_or(glm::vec3(1.0f));
    } else if (cls == "scale") {
      // tex * scale: a texture or colour times a value or a constant float texture.
      tex = spectrum_operand(p, "tex", 1.0f, d);
      if (const auto c = p.get_rgb("scale")) {
        tex.factor *= *c;
      } else if (const auto f = float_operand(p, "scale", 1.0)) {
        tex.factor *= static_cast<float>(*f);
      } else {
        warn(d.at, "a \"scale\" texture's non-constant texture scale ignored");
      }
    } else if (cls == "checkerboard" && p.get_int("dimension", 2) == 2) {
      tex = checkerboard(p, d);
    } else if (cls == "mix") {
      // pbrt-v4's MixTexture: (1 - amount) tex1 + amount tex2.
      const SpectrumTexture a = spectrum_operand(p, "tex1", 0.0f, d);
      const SpectrumTexture b = spectrum_operand(p, "tex2", 1.0f, d);
      tex = blend(a, b, mix_amount(p, d), d);
    } else {
      warn(d.at, "spectrum texture \"" + cls + (cls == "checkerboard" ? "\" (3-D)" : "\"") +
                     " replaced by grey 0.5");
      tex.factor = glm::vec3(0.5f);
      for (const PbrtParam& q : p.list) q.used = true;
    }
    warn_unused(p, "Texture");
    spectrum_textures_[name] = tex;
  }

  // A float texture of constants is its value (constant, scale, mix); others are not kept, and the
  // parameters they feed keep their defaults with a warning (scalar).
  void float_texture(const std::string& name, const std::string& cls, const PbrtParams& p,
                     const PbrtToken& d) {
    std::optional<double> v;
    if (cls == "constant") {
      v = p.get_float("value", 1.0);
    } else if (cls == "scale") {
      const auto a = float_operand(p, "tex", 1.0), b = float_operand(p, "scale", 1.0);
      if (a && b) v = *a * *b;
    } else if (cls == "mix") {
      const auto a = float_operand(p, "tex1", 0.0), b = float_operand(p, "tex2", 1.0);
      const auto w = float_operand(p, "amount", 0.5);
      if (a && b && w) v = (1.0 - *w) * *a + *w * *b;
    }
    if (v) {
      float_textures_[name] = *v;
    } else {
      warn(d.at, "float texture \"" + cls + "\" not supported (its parameter keeps its default)");
      for (const PbrtParam& q : p.list) q.used = true;
    }
  }

  // A float parameter given as a value or a constant float texture; nullopt for another texture.
  std::optional<double> float_operand(const PbrtParams& p, std::string_view name, double fallback) {
    std::string tex;
    if (const std::optional<double> v = p.get_float_or_texture(name, &tex)) return v;
    if (tex.empty()) return fallback;
    const auto it = float_textures_.find(tex);
    if (it == float_textures_.end()) return std::nullopt;
    return it->second;
  }

  // A spectrum parameter of a texture: the texture it names, or its constant colour.
  SpectrumTexture spectrum_operand(const PbrtParams& p, std::string_view name, float fallback,
                                   const PbrtToken& d) {
    const std::string tex = p.texture_name(name);
    if (!tex.empty()) {
      const auto it = spectrum_textures_.find(tex);
      if (it == spectrum_textures_.end()) fail(d.at, "undefined spectrum texture \"" + tex + "\"");
      return it->second;
    }
    SpectrumTexture c;
    c.factor = p.get_rgb(name).value_or(glm::vec3(fallback));
    return c;
  }

  // The mean colour of a texture (the checkerboard's two colours weigh equally).
  glm::vec3 mean_colour(const SpectrumTexture& t) const {
    if (t.image < 0) return t.factor;
    const Texture& tex = out_.scene.textures[static_cast<size_t>(t.image)];
    glm::dvec3 sum(0.0);
    for (const glm::vec3& c : tex.texels()) sum += glm::dvec3(c);
    return t.factor * glm::vec3(sum / static_cast<double>(tex.texels().size()));
  }

  int32_t add_texture(Texture texture) {
    out_.scene.textures.push_back(std::move(texture));
    return static_cast<int32_t>(out_.scene.textures.size() - 1);
  }

  // pbrt-v4's 2-D checkerboard with its uv mapping, as tritrace's procedural checkerboard texture
  // (exact); a side that is itself a texture is replaced by its mean colour, with a warning.
  SpectrumTexture checkerboard(const PbrtParams& p, const PbrtToken& d) {
    const std::string mapping = p.get_string("mapping", "uv");
    if (mapping != "uv") warn(d.at, "texture mapping \"" + mapping + "\" replaced by \"uv\"");
    Checkerboard board;
    board.scale = glm::vec2(static_cast<float>(p.get_float("uscale", 1.0)),
                            static_cast<float>(p.get_float("vscale", 1.0)));
    board.delta = glm::vec2(static_cast<float>(p.get_float("udelta", 0.0)),
                            static_cast<float>(p.get_float("vdelta", 0.0)));
    const SpectrumTexture a = spectrum_operand(p, "tex1", 1.0f, d);
    const SpectrumTexture b = spectrum_operand(p, "tex2", 0.0f, d);
    if (a.image >= 0 || b.image >= 0) {
      warn(d.at, "a checkerboard of textures: each textured square replaced by its mean colour");
    }
    board.even = mean_colour(a);
    board.odd = mean_colour(b);
    p.find("dimension");
    SpectrumTexture t;
    t.image = add_texture(Texture::checkerboard(board));
    return t;
  }

  // A mix's "amount": a value or a constant float texture; another texture is taken as 0.5.
  float mix_amount(const PbrtParams& p, const PbrtToken& d) {
    const std::optional<double> w = float_operand(p, "amount", 0.5);
    if (w) return static_cast<float>(*w);
    warn(d.at, "a mix's non-constant \"amount\" texture approximated by 0.5");
    return 0.5f;
  }

  // (1 - w) a + w b: exact for two constants, two factors of one texture, or a texture (image or
  // checkerboard) and a constant, which is baked texel by texel (exact under bilinear filtering,
  // whose weights sum to 1); two different textures are approximated by the one of larger weight.
  SpectrumTexture blend(const SpectrumTexture& a, const SpectrumTexture& b, float w,
                        const PbrtToken& d) {
    if (w == 0.0f) return a;
    if (w == 1.0f) return b;
    if (a.same_lookup(b)) {
      SpectrumTexture t = a;
      t.factor = (1.0f - w) * a.factor + w * b.factor;
      return t;
    }
    if (a.image >= 0 && b.image >= 0) {
      warn(d.at, "a mix of two textures approximated by the one of larger weight");
      return w > 0.5f ? b : a;
    }
    const bool a_textured = a.image >= 0;
    const SpectrumTexture& textured = a_textured ? a : b;
    const glm::vec3 constant = a_textured ? w * b.factor : (1.0f - w) * a.factor;
    const float weight = a_textured ? 1.0f - w : w;
    const Texture& source = out_.scene.textures[static_cast<size_t>(textured.image)];
    if (baked_texels_ + source.texels().size() > kMaxBakedTexels) {
      warn(d.at, "a mix approximated by the side of larger weight (mixes would bake more than " +
                     std::to_string(kMaxBakedTexels) + " texels)");
      return w > 0.5f ? b : a;
    }
    baked_texels_ += source.texels().size();
    Texture baked = source.mapped(weight * textured.factor, constant);
    SpectrumTexture t = textured;  // its uv mapping
    t.image = add_texture(std::move(baked));
    t.factor = glm::vec3(1.0f);
    return t;
  }

  int32_t image_texture(const std::string& name, const std::string& encoding, const PbrtToken& d) {
    if (name.empty()) fail(d.at, "imagemap needs a \"string filename\"");
    if (!options_.read_images)
      fail(d.at, "imagemap \"" + name + "\": image files are not read here");
    const std::string file = resolve(name, d.at);
    if (const auto it = texture_files_.find(file); it != texture_files_.end()) return it->second;
    try {
      std::string ext = fs::path(file).extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(),
                     [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
      if (ext == ".exr" || ext == ".hdr") {
        Image image = read_image_float(file);
        out_.scene.textures.emplace_back(image.width(), image.height(), image.pixels());
      } else {
        if (!encoding.empty() && encoding != "sRGB") {
          warn(d.at, "imagemap encoding \"" + encoding + "\" read as sRGB");
        }
        const std::string bytes = read_input_file(file);
        out_.scene.textures.push_back(Texture::from_srgb8(decode_texture_image(
            std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), file)));
      }
    } catch (const Error& e) {
      fail(d.at, "imagemap \"" + name + "\": " + e.reason());
    }
    const auto index = static_cast<int32_t>(out_.scene.textures.size() - 1);
    texture_files_[file] = index;
    return index;
  }

  // A colour parameter: its rgb/spectrum value, or a texture's (an image into `texture`).
  glm::vec3 color(const PbrtParams& p, std::string_view name, glm::vec3 fallback,
                  TextureRef* texture, const PbrtToken& d) {
    const std::string tex = p.texture_name(name);
    if (!tex.empty()) {
      const auto it = spectrum_textures_.find(tex);
      if (it == spectrum_textures_.end()) fail(d.at, "undefined spectrum texture \"" + tex + "\"");
      if (it->second.image >= 0) {
        if (texture) {
          texture->index = it->second.image;
          const SpectrumTexture& t = it->second;
          const float m[6] = {t.scale.x, 0.0f, 0.0f, t.scale.y, t.delta.x, t.delta.y};
          std::copy(m, m + 6, texture->transform);
        } else {
          warn(d.at, "an image texture on \"" + std::string(name) + "\" replaced by white");
        }
      }
      return it->second.factor;
    }
    return p.get_rgb(name).value_or(fallback);
  }

  double scalar(const PbrtParams& p, std::string_view name, double fallback, const PbrtToken& d) {
    std::string tex;
    const std::optional<double> v = p.get_float_or_texture(name, &tex);
    if (v) return *v;
    if (tex.empty()) return fallback;
    const auto it = float_textures_.find(tex);
    if (it != float_textures_.end()) return it->second;
    warn(d.at,
         "a non-constant float texture on \"" + std::string(name) + "\" replaced by its default");
    return fallback;
  }

  // pbrt's roughness (remapped or not, u and v averaged) as tritrace's perceptual roughness, whose
  // square is the GGX alpha.
  float roughness(const PbrtParams& p, const std::string& prefix, const PbrtToken& d) {
    const double r = scalar(p, prefix + "roughness", 0.0, d);
    double u = scalar(p, prefix + "uroughness", r, d), v = scalar(p, prefix + "vroughness", r, d);
    if (u != v) warn(d.at, "anisotropic roughness approximated by the mean of u and v");
    const bool remap = p.get_bool("remaproughness", true);
    // pbrt-v4's RoughnessToAlpha is sqrt(roughness).
    const auto alpha = [&](double x) {
      return remap ? std::sqrt(std::max(x, 0.0)) : std::max(x, 0.0);
    };
    const double a = 0.5 * (alpha(u) + alpha(v));
    return static_cast<float>(std::clamp(std::sqrt(a), 0.0, 1.0));
  }

  float index_of_refraction(const PbrtParams& p, const PbrtToken& d) {
    glm::vec3 eta(1.5f);
    if (const auto e = p.get_rgb("eta")) eta = *e;
    if (eta.x != eta.y || eta.y != eta.z) warn(d.at, "dispersion ignored: the green index is used");
    float ior = eta.y;
    if (ior == 0.0f) ior = 1.5f;  // pbrt's "no index": its default
    ior = std::clamp(ior, 1.0f / kMaxIndex, kMaxIndex);
    if (!ior_supported(ior)) ior = 1.0f;
    return ior;
  }

  uint32_t add_material(const Material& m) {
    out_.scene.materials.push_back(m);
    return static_cast<uint32_t>(out_.scene.materials.size() - 1);
  }

  uint32_t material(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    Material m;
    const std::string what = "Material \"" + type + "\"";
    if (type == "diffuse") {
      m.type = MaterialType::kDiffuse;
      m.albedo = color(p, "reflectance", glm::vec3(0.5f), &m.albedo_texture, d);
    } else if (type == "conductor" || type == "coatedconductor") {
      const std::string prefix = type == "conductor" ? "" : "conductor.";
      glm::vec3 eta = named_spectrum_rgb("metal-Cu-eta").value();
      glm::vec3 k = named_spectrum_rgb("metal-Cu-k").value();
      if (const auto r = p.get_rgb("reflectance")) {
        // pbrt: a reflectance in place of eta and k, the index that has it at normal incidence.
        eta = glm::vec3(1.0f);
        const glm::vec3 rr = glm::clamp(*r, glm::vec3(0.0f), glm::vec3(0.9999f));
        k = 2.0f * glm::sqrt(rr) / glm::sqrt(glm::vec3(1.0f) - rr);
      } else {
        eta = p.get_rgb(prefix + "eta").value_or(eta);
        k = p.get_rgb(prefix + "k").value_or(k);
      }
      eta = glm::clamp(eta, glm::vec3(0.01f), glm::vec3(kMaxIndex));
      k = glm::clamp(k, glm::vec3(0.0f), glm::vec3(100.0f));
      glm::vec3 f0;
      for (int c = 0; c < 3; ++c) {
        const float n = eta[c], kk = k[c];
        f0[c] = ((n - 1) * (n - 1) + kk * kk) / ((n + 1) * (n + 1) + kk * kk);
      }
      m.roughness = roughness(p, prefix, d);
      if (type == "conductor") {
        m.type = MaterialType::kConductor;
        m.conductor_eta = eta;
        m.conductor_k = k;
        m.albedo = f0;
      } else {
        warn(d.at, "coatedconductor approximated by a principled metal (the coat is left out)");
        m.type = MaterialType::kPrincipled;
        m.metallic = 1.0f;
        m.albedo = f0;
        p.find("interface.roughness");
        p.find("interface.eta");
        p.find("thickness");
      }
    } else if (type == "dielectric" || type == "thindielectric") {
      m.type = MaterialType::kDielectric;
      m.albedo = glm::vec3(1.0f);
      m.ior = index_of_refraction(p, d);
      if (type == "thindielectric") {
        warn(d.at, "thindielectric approximated by a dielectric of the same index");
      } else {
        m.roughness = roughness(p, "", d);
      }
    } else if (type == "coateddiffuse") {
      m.type = MaterialType::kPrincipled;
      m.albedo = color(p, "reflectance", glm::vec3(0.5f), &m.albedo_texture, d);
      m.roughness = roughness(p, "", d);
      m.ior = index_of_refraction(p, d);
      if (m.ior == 1.0f) m.ior = 1.5f;
      p.find("thickness");
      p.find("albedo");
      p.find("g");
      p.find("maxdepth");
      p.find("nsamples");
    } else if (type == "diffusetransmission") {
      warn(d.at, "diffusetransmission approximated by diffuse (its transmission is left out)");
      m.albedo = color(p, "reflectance", glm::vec3(0.25f), &m.albedo_texture, d);
      p.find("transmittance");
    } else if (type == "interface" || type == "") {
      // A boundary between media: no surface at all, which a dielectric of index 1 is.
      m.type = MaterialType::kDielectric;
      m.albedo = glm::vec3(1.0f);
      m.ior = 1.0f;
    } else if (type == "mix") {
      // The material with the larger weight (pbrt picks one per point stochastically).
      const PbrtParam* names = p.find("materials");
      const double amount = scalar(p, "amount", 0.5, d);
      warn(d.at, "mix approximated by the material of the larger weight");
      if (names && names->strings.size() == 2) {
        const auto it = named_materials_.find(names->strings[amount > 0.5 ? 1 : 0]);
        if (it != named_materials_.end()) return it->second;
      }
      m.albedo = glm::vec3(0.5f);
    } else {
      warn(d.at, what + " not supported: replaced by diffuse grey 0.5");
      m.albedo = glm::vec3(0.5f);
      for (const PbrtParam& q : p.list) q.used = true;
    }
    for (const char* k : {"displacement", "normalmap"}) {
      if (p.find(k)) warn(d.at, std::string("material \"") + k + "\" ignored");
    }
    warn_unused(p, what);
    m.albedo = glm::clamp(m.albedo, glm::vec3(0.0f), glm::vec3(1.0f));
    return add_material(m);
  }

  // A shape's "float alpha": pbrt-v4 ignores a hit on it where a hash of the ray is above alpha
  // (every hit at alpha 0), which is tritrace's blend mode with a constant alpha. An alpha
  // texture is warned and ignored.
  float shape_alpha(const PbrtParams& p, const PbrtToken& d) {
    if (!p.texture_name("alpha").empty()) {
      warn(d.at, "shape \"texture alpha\" (textured cut-outs) ignored");
      return 1.0f;
    }
    const double a = p.get_float("alpha", 1.0);
    if (!(a >= 0.0 && a <= 1.0)) fail(d.at, "\"float alpha\" must be from 0 to 1");
    return static_cast<float>(a);
  }

  uint32_t current_material() {
    const uint32_t surface = current_surface_material();
    if (shape_alpha_ >= 1.0f) return surface;
    const auto key = std::make_pair(surface, shape_alpha_);
    if (const auto it = blended_.find(key); it != blended_.end()) return it->second;
    Material m = out_.scene.materials[surface];
    m.alpha_mode = AlphaMode::kBlend;
    m.alpha = shape_alpha_;
    const uint32_t index = add_material(m);
    blended_[key] = index;
    return index;
  }

  uint32_t current_surface_material() {
    if (gs_.material < 0) {
      if (default_material_ < 0) {
        Material m;
        m.albedo = glm::vec3(0.5f);
        default_material_ = static_cast<int>(add_material(m));
      }
      gs_.material = default_material_;
    }
    if (!gs_.area_emission) return static_cast<uint32_t>(gs_.material);
    // The surface material with the area light's emission, made once per combination.
    const auto key = std::make_tuple(gs_.material, gs_.area_emission->x, gs_.area_emission->y,
                                     gs_.area_emission->z, gs_.area_two_sided);
    if (const auto it = emissive_.find(key); it != emissive_.end()) return it->second;
    Material m = out_.scene.materials[static_cast<size_t>(gs_.material)];
    m.emission = *gs_.area_emission;
    m.two_sided = gs_.area_two_sided;
    const uint32_t index = add_material(m);
    emissive_[key] = index;
    return index;
  }

  // --- lights --------------------------------------------------------------------------------

  glm::vec3 light_spectrum(const PbrtParams& p, std::string_view name) {
    const glm::vec3 rgb = p.get_rgb(name).value_or(glm::vec3(1.0f));
    return rgb * static_cast<float>(p.get_float("scale", 1.0));
  }

  // Whether a light's value survived the scale and the CTM (non-finite inputs are refused).
  static bool finite_light(glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
  }

  // A direction given in the light's space, moved to world space by the CTM's linear part (not its
  // inverse transpose: it is a direction of travel, not a normal) and normalised; zero when it
  // vanishes.
  static glm::vec3 moved_direction(const Placement& place, dvec3 v) {
    const dvec3 w = glm::dmat3(place.m) * v;
    const double len = glm::length(w);
    return len > 0.0 && std::isfinite(len) ? glm::vec3(w / len) : glm::vec3(0.0f);
  }

  void light(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    const Placement place(gs_.ctm);
    if (type == "point") {
      glm::vec3 intensity = light_spectrum(p, "I");
      const double power = p.get_float("power", -1.0);
      // pbrt-v4: "power" is the radiant power in place of the intensity's scale.
      if (power > 0.0) intensity *= static_cast<float>(power / (4.0 * std::numbers::pi));
      const dvec3 from = p.get_point("from").value_or(dvec3(0.0));
      const glm::vec3 position = place.point(glm::vec3(from));
      out_.scene.lights.push_back(
          {position, intensity * static_cast<float>(4.0 * std::numbers::pi)});
    } else if (type == "spot") {
      // pbrt-v4's SpotLight: I(w) = I scale smoothstep(cos(theta); cos(coneangle),
      // cos(coneangle - conedelta)), the axis from "from" to "to", both moved by the CTM.
      const double cone = p.get_float("coneangle", 30.0);
      const double delta = p.get_float("conedelta", 5.0);
      if (!(cone > 0.0 && cone <= 180.0)) {
        fail(d.at, "spot light \"coneangle\" must be more than 0 and at most 180 degrees");
      }
      if (!(delta > 0.0 && delta <= cone)) {
        fail(d.at, "spot light \"conedelta\" must be more than 0 and at most \"coneangle\"");
      }
      SpotLight l;
      l.falloff = SpotFalloff::kSmoothstep;
      l.cos_outer = static_cast<float>(std::cos(cone * std::numbers::pi / 180.0));
      l.cos_inner = static_cast<float>(std::cos((cone - delta) * std::numbers::pi / 180.0));
      if (!(l.cos_inner > l.cos_outer)) {
        fail(d.at, "spot light \"conedelta\" is too small to tell the cones' cosines apart");
      }
      l.intensity = light_spectrum(p, "I");
      const double power = p.get_float("power", -1.0);
      // pbrt-v4: "power" is the radiant power in place of the intensity's scale, divided by the
      // cone's solid-angle integral 2 pi (1 - cos_start + (cos_start - cos_end) / 2).
      if (power > 0.0) {
        SpotLight unit = l;
        unit.intensity = glm::vec3(1.0f);
        l.intensity *= static_cast<float>(power / spot_light_power(unit).x);
      }
      const dvec3 from = p.get_point("from").value_or(dvec3(0.0));
      const dvec3 to = p.get_point("to").value_or(dvec3(0.0, 0.0, 1.0));
      l.position = place.point(glm::vec3(from));
      l.direction = moved_direction(place, to - from);
      if (l.direction == glm::vec3(0.0f)) fail(d.at, "spot light \"from\" and \"to\" coincide");
      if (!finite_light(l.intensity) || !finite_light(l.position)) {
        fail(d.at, "spot light beyond float range");
      }
      out_.scene.spot_lights.push_back(l);
    } else if (type == "distant") {
      // pbrt-v4's DistantLight: radiance L scale arriving from direction from - to, which is the
      // irradiance it gives a surface facing it.
      glm::vec3 irradiance = light_spectrum(p, "L");
      const double illuminance = p.get_float("illuminance", -1.0);
      if (illuminance > 0.0) irradiance *= static_cast<float>(illuminance);
      const dvec3 from = p.get_point("from").value_or(dvec3(0.0));
      const dvec3 to = p.get_point("to").value_or(dvec3(0.0, 0.0, 1.0));
      const glm::vec3 travel = moved_direction(place, to - from);
      if (travel == glm::vec3(0.0f)) fail(d.at, "distant light \"from\" and \"to\" coincide");
      if (!finite_light(irradiance)) fail(d.at, "distant light beyond float range");
      out_.scene.directional_lights.push_back({travel, irradiance});
    } else if (type == "infinite") {
      const std::string file = p.get_string("filename", "");
      if (file.empty()) {
        out_.scene.environment += light_spectrum(p, "L");
      } else {
        environment_map(file, static_cast<float>(p.get_float("scale", 1.0)), place, d);
      }
      if (p.find("illuminance")) {
        warn(d.at,
             "an infinite light's \"illuminance\" ignored (L or the image and scale are used)");
      }
      p.find("portal");  // only guides pbrt's sampling
    } else {
      warn(d.at, "LightSource \"" + type + "\" not supported: skipped");
      return;
    }
    warn_unused(p, "LightSource \"" + type + "\"");
  }

  // pbrt-v4's image infinite light: a square image in the equal-area octahedral mapping
  // (Clarberg, "Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", 2008), resampled to
  // tritrace's latitude-longitude map of world directions through the light's transform.
  void environment_map(const std::string& name, float scale, const Placement& place,
                       const PbrtToken& d) {
    if (!options_.read_images) {
      fail(d.at, "infinite light \"" + name + "\": image files are not read here");
    }
    const std::string file = resolve(name, d.at);
    Image image;
    try {
      image = read_image_float(file);
    } catch (const Error& e) {
      fail(d.at, "infinite light \"" + name + "\": " + e.reason());
    }
    if (image.width() != image.height()) {
      fail(d.at, "infinite light \"" + name +
                     "\": pbrt-v4 environment maps are square (equal-area octahedral), got " +
                     std::to_string(image.width()) + "x" + std::to_string(image.height()));
    }
    const int side = image.width();
    auto map = std::make_shared<EnvironmentMap>();
    map->height = std::max(2, side);
    map->width = 2 * map->height;
    map->scale = scale;
    map->path = file;
    map->texels.resize(static_cast<size_t>(map->width) * static_cast<size_t>(map->height));
    const glm::dmat3 light_from_world = glm::inverse(glm::dmat3(place.m));
    for (int y = 0; y < map->height; ++y) {
      for (int x = 0; x < map->width; ++x) {
        // tritrace's direction of texel (x, y) (scene.h, EnvironmentMap).
        const double theta = std::numbers::pi * (y + 0.5) / map->height;
        const double phi = 2.0 * std::numbers::pi * ((x + 0.5) / map->width - 0.5);
        const dvec3 world(std::sin(theta) * std::sin(phi), -std::cos(theta),
                          std::sin(theta) * std::cos(phi));
        const dvec3 w = glm::normalize(light_from_world * world);
        // Equal-area sphere to square: r from z, the split of |u| + |v| from the azimuth.
        const double r = std::sqrt(std::max(0.0, 1.0 - std::abs(w.z)));
        const double a = std::atan2(std::abs(w.y), std::abs(w.x));   // [0, pi/2]
        const double diff = r * (4.0 * a / std::numbers::pi - 1.0);  // |v| - |u|
        const double sum = w.z >= 0.0 ? r : 2.0 - r;                 // |u| + |v|
        const double up = 0.5 * (sum - diff), vp = 0.5 * (sum + diff);
        const double u = std::copysign(up, w.x), v = std::copysign(vp, w.y);
        const int px = std::clamp(static_cast<int>((u + 1.0) * 0.5 * side), 0, side - 1);
        const int py = std::clamp(static_cast<int>((v + 1.0) * 0.5 * side), 0, side - 1);
        map->texels[static_cast<size_t>(y) * static_cast<size_t>(map->width) +
                    static_cast<size_t>(x)] =
            image.pixels()[static_cast<size_t>(py) * static_cast<size_t>(side) +
                           static_cast<size_t>(px)];
      }
    }
    if (out_.scene.environment_map) warn(d.at, "a second image infinite light replaces the first");
    out_.scene.environment_map = std::move(map);
  }

  void area_light(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    if (type != "diffuse") {
      warn(d.at, "AreaLightSource \"" + type + "\" not supported: skipped");
      return;
    }
    gs_.area_emission = light_spectrum(p, "L");
    gs_.area_two_sided = p.get_bool("twosided", false);
    if (p.find("power")) warn(d.at, "an area light's \"power\" ignored (L and scale are used)");
    if (p.find("filename")) warn(d.at, "an area light's image \"filename\" ignored");
    warn_unused(p, "AreaLightSource");
  }

  // --- shapes --------------------------------------------------------------------------------

  Soup& target() { return object_ ? *object_ : world_; }

  // Adds an object-space mesh placed by the current transform. Each triangle's front (where
  // tritrace's lab normal cross(e2, e1) points) is made pbrt's: the side of its vertex normals when
  // it has them, else of cross(e1, e2) in object space; ReverseOrientation flips both (pbrt-v4's
  // triangle meshes negate N under it); placed by a mirroring transform the normal is carried over
  // (pbrt flips it back), so the corners swap.
  void add_mesh(const std::vector<glm::vec3>& positions, const std::vector<uint32_t>& indices,
                const std::vector<glm::vec3>& normals, const std::vector<glm::vec2>& uvs) {
    const Placement place(gs_.ctm);
    const uint32_t m = current_material();
    Soup& soup = target();
    for (size_t t = 0; t + 2 < indices.size(); t += 3) {
      const uint32_t i[3] = {indices[t], indices[t + 1], indices[t + 2]};
      const glm::vec3 a = positions[i[0]], b = positions[i[1]], c = positions[i[2]];
      const glm::dvec3 face = glm::cross(dvec3(b - a), dvec3(c - a));
      dvec3 front = face;
      if (!normals.empty()) {
        const dvec3 sum = dvec3(normals[i[0]]) + dvec3(normals[i[1]]) + dvec3(normals[i[2]]);
        if (glm::dot(sum, sum) > 0.0) front = sum;
      }
      if (gs_.reverse) front = -front;
      bool swap = glm::dot(face, front) > 0.0;
      if (place.mirrors) swap = !swap;
      const int order[3] = {0, swap ? 2 : 1, swap ? 1 : 2};
      glm::vec3 p[3], n[3];
      glm::vec2 uv[3];
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = i[order[k]];
        p[k] = place.point(positions[v]);
        if (!normals.empty()) n[k] = place.direction(gs_.reverse ? -normals[v] : normals[v]);
        if (!uvs.empty()) uv[k] = uvs[v];
      }
      soup.add(p, normals.empty() ? nullptr : n, uvs.empty() ? nullptr : uv, m);
    }
    ++out_.stats.meshes;
  }

  // An instance of an object definition, as a tritrace instance of the object's triangles: one
  // prototype per object, and a second with every triangle's corners swapped for mirroring
  // placements (tritrace keeps the vertex order's front, pbrt carries the normal along). Placed
  // once the scene's own triangles are known, which come first in tritrace's numbering.
  void instance(const std::string& name, const Soup& object, const dmat4& m,
                const PbrtLocation& at) {
    const Placement place(m);
    const auto key = std::make_pair(name, place.mirrors);
    auto it = prototype_of_.find(key);
    if (it == prototype_of_.end()) {
      Soup copy = object;
      if (place.mirrors) {
        for (size_t t = 0; t < copy.material.size(); ++t) {
          std::swap(copy.corners[3 * t + 1], copy.corners[3 * t + 2]);
          if (copy.has_normals) std::swap(copy.normals[3 * t + 1], copy.normals[3 * t + 2]);
          if (copy.has_uvs) std::swap(copy.uvs[3 * t + 1], copy.uvs[3 * t + 2]);
        }
      }
      TriangleMesh mesh;
      add_soup(mesh, copy, at.describe());
      int64_t index = -1;
      if (!mesh.empty()) {
        index = static_cast<int64_t>(out_.scene.prototypes.size());
        out_.scene.prototypes.push_back(std::move(mesh));
      }
      it = prototype_of_.emplace(key, index).first;
    }
    if (it->second >= 0) placements_.push_back({static_cast<uint32_t>(it->second), m, at});
    ++out_.stats.meshes;
  }

  // Adds a soup's triangles through the loader's one gate (degenerate and non-finite ones are
  // dropped and counted); `subject` names the place in the error for too many.
  void add_soup(TriangleMesh& mesh, const Soup& soup, const std::string& subject) {
    AddOptions options;
    options.max_triangles = kMaxSceneTriangles;
    const AddResult r = add_all_checked(
        mesh, CornerView(soup.corners), soup.material,
        soup.has_normals ? std::span<const glm::vec3>(soup.normals) : std::span<const glm::vec3>(),
        soup.has_uvs ? std::span<const glm::vec2>(soup.uvs) : std::span<const glm::vec2>(), options,
        out_.stats);
    if (r == AddResult::kTooManyTriangles) {
      throw Error(subject, "more than " + std::to_string(kMaxSceneTriangles) + " triangles");
    }
  }

  template <typename T>
  std::vector<T> vectors(const PbrtParams& p, std::string_view name,
                         std::initializer_list<std::string_view> types, int dims,
                         const PbrtToken& d) {
    const std::vector<double>* v = p.get_numbers(name, types);
    std::vector<T> out;
    if (!v) return out;
    if (v->size() % static_cast<size_t>(dims) != 0) {
      fail(d.at,
           "\"" + std::string(name) + "\" needs a multiple of " + std::to_string(dims) + " values");
    }
    for (size_t i = 0; i + static_cast<size_t>(dims) <= v->size(); i += static_cast<size_t>(dims)) {
      T x{};
      for (int k = 0; k < dims; ++k) x[k] = static_cast<float>((*v)[i + static_cast<size_t>(k)]);
      out.push_back(x);
    }
    return out;
  }

  void check_indices(const std::vector<uint32_t>& idx, size_t vertices, const PbrtToken& d) {
    for (uint32_t i : idx) {
      if (i >= vertices) {
        fail(d.at, "vertex index " + std::to_string(i) + " out of range (" +
                       std::to_string(vertices) + " vertices)");
      }
    }
  }

  void shape(const std::string& type, const PbrtParams& p, const PbrtToken& d) {
    const std::string what = "Shape \"" + type + "\"";
    shape_alpha_ = shape_alpha(p, d);
    if (type == "trianglemesh" || type == "bilinearmesh" || type == "loopsubdiv") {
      const auto positions = vectors<glm::vec3>(p, "P", {"point3"}, 3, d);
      auto normals = vectors<glm::vec3>(p, "N", {"normal"}, 3, d);
      auto uvs = vectors<glm::vec2>(p, "uv", {"point2", "float"}, 2, d);
      if (uvs.empty()) uvs = vectors<glm::vec2>(p, "st", {"point2", "float"}, 2, d);
      if (positions.empty()) fail(d.at, what + " needs \"point3 P\"");
      const size_t corners = type == "bilinearmesh" ? 4 : 3;
      std::vector<int> raw = p.get_ints("indices");
      if (raw.empty()) {
        if (positions.size() != corners) fail(d.at, what + " needs \"integer indices\"");
        for (size_t k = 0; k < corners; ++k) raw.push_back(static_cast<int>(k));
      }
      if (raw.size() % corners != 0) {
        fail(d.at,
             what + ": the number of indices must be a multiple of " + std::to_string(corners));
      }
      std::vector<uint32_t> idx;
      for (int i : raw) {
        if (i < 0) fail(d.at, what + ": negative vertex index " + std::to_string(i));
        idx.push_back(static_cast<uint32_t>(i));
      }
      check_indices(idx, positions.size(), d);
      if (!normals.empty() && normals.size() != positions.size()) {
        fail(d.at, what + ": \"N\" needs one normal per vertex of \"P\"");
      }
      if (!uvs.empty() && uvs.size() != positions.size()) {
        fail(d.at, what + ": \"uv\" needs one pair per vertex of \"P\"");
      }
      if (type == "bilinearmesh") {
        // Patch corners p00 p10 p01 p11: triangles (p00, p10, p11) and (p00, p11, p01), whose
        // cross(e1, e2) is pbrt's patch normal dp/du x dp/dv.
        std::vector<uint32_t> tri;
        for (size_t q = 0; q < idx.size(); q += 4) {
          tri.insert(tri.end(), {idx[q], idx[q + 1], idx[q + 3], idx[q], idx[q + 3], idx[q + 2]});
        }
        idx = std::move(tri);
      }
      for (const char* k : {"S", "faceIndices"}) p.find(k);
      if (type == "loopsubdiv") {
        int levels = p.get_int("levels", 3);
        if (levels < 0) fail(d.at, "\"integer levels\" must not be negative");
        // Each level makes four triangles of one.
        int64_t triangles = static_cast<int64_t>(idx.size() / 3);
        int allowed = 0;
        while (allowed < levels && triangles * 4 <= static_cast<int64_t>(kMaxSceneTriangles)) {
          triangles *= 4;
          ++allowed;
        }
        if (allowed < levels) {
          warn(d.at, "loopsubdiv levels reduced to " + std::to_string(allowed) +
                         " (more would exceed the triangle limit)");
        }
        if (!normals.empty() || !uvs.empty()) warn(d.at, "loopsubdiv \"N\" and \"uv\" ignored");
        add_analytic(loop_subdivide(positions, idx, allowed));
      } else {
        add_mesh(positions, idx, normals, uvs);
      }
    } else if (type == "plymesh") {
      const std::string name = p.get_string("filename", "");
      if (name.empty()) fail(d.at, "plymesh needs a \"string filename\"");
      ImportedMesh mesh;
      try {
        mesh = options_.read_mesh ? options_.read_mesh(resolve(name, d.at))
                                  : import_mesh_file(resolve(name, d.at));
      } catch (const Error& e) {
        fail(d.at, "plymesh \"" + name + "\": " + e.reason());
      }
      if (p.find("displacement")) warn(d.at, "plymesh displacement ignored");
      // One vertex per corner (the importer's normals and uvs are per corner).
      std::vector<glm::vec3> positions(mesh.triangles() * 3), normals;
      std::vector<glm::vec2> uvs;
      const CornerView view = mesh.corner_view();
      for (size_t k = 0; k < positions.size(); ++k) positions[k] = view[k];
      if (!mesh.normals.empty()) normals.assign(mesh.normals.begin(), mesh.normals.end());
      if (!mesh.uvs.empty()) uvs.assign(mesh.uvs.begin(), mesh.uvs.end());
      std::vector<uint32_t> idx(positions.size());
      for (size_t k = 0; k < idx.size(); ++k) idx[k] = static_cast<uint32_t>(k);
      add_mesh(positions, idx, normals, uvs);
    } else if (type == "sphere") {
      const double r = p.get_float("radius", 1.0);
      const PbrtMesh m = tessellate_sphere(r, p.get_float("zmin", -r), p.get_float("zmax", r),
                                           p.get_float("phimax", 360.0));
      add_analytic(m);
    } else if (type == "disk") {
      const PbrtMesh m =
          tessellate_disk(p.get_float("height", 0.0), p.get_float("radius", 1.0),
                          p.get_float("innerradius", 0.0), p.get_float("phimax", 360.0));
      add_analytic(m);
    } else if (type == "cylinder") {
      const PbrtMesh m =
          tessellate_cylinder(p.get_float("radius", 1.0), p.get_float("zmin", -1.0),
                              p.get_float("zmax", 1.0), p.get_float("phimax", 360.0));
      add_analytic(m);
    } else {
      shape_alpha_ = 1.0f;
      warn(d.at, what + " not supported: skipped");
      return;
    }
    shape_alpha_ = 1.0f;
    p.find("emissionfilename");
    warn_unused(p, what);
  }

  // A tessellated quadric (or subdivision surface): its normals point outward, and inward under
  // ReverseOrientation (add_mesh flips them).
  void add_analytic(const PbrtMesh& m) { add_mesh(m.positions, m.indices, m.normals, m.uvs); }

  // --- the result ----------------------------------------------------------------------------

  void finish() {
    if (object_)
      throw Error(path_, "ObjectBegin \"" + object_name_ + "\" is not closed by ObjectEnd");
    if (!stack_.empty()) {
      warn(stack_.back().at,
           "AttributeBegin without a matching AttributeEnd at the end of the file");
    }
    // The camera: pbrt's camera space has +x to the image's right and +y up.
    const dmat4 world_from_camera = glm::inverse(camera_from_world_);
    const dvec3 eye = dvec3(world_from_camera * glm::dvec4(0, 0, 0, 1));
    const dvec3 right = glm::normalize(dvec3(world_from_camera * glm::dvec4(1, 0, 0, 0)));
    const dvec3 up = glm::normalize(dvec3(world_from_camera * glm::dvec4(0, 1, 0, 0)));
    const dvec3 forward = glm::normalize(dvec3(world_from_camera * glm::dvec4(0, 0, 1, 0)));
    CameraSpec& c = out_.camera;
    c.position = glm::vec3(eye);
    c.look_at = glm::vec3(eye + forward);
    c.up = glm::vec3(up);
    if (!Camera::is_valid_look_at(c.position, c.look_at, c.up)) {
      fail(camera_at_, "the camera transform is degenerate");
    }
    // The lens: pbrt's lensradius and focaldistance are camera-space lengths, which a scaling
    // camera transform stretches as it stretches camera-space z.
    if (lens_radius_ > 0.0) {
      const double scale = glm::length(dvec3(world_from_camera * glm::dvec4(0, 0, 1, 0)));
      c.aperture_radius = static_cast<float>(lens_radius_ * scale);
      c.focus_distance = static_cast<float>(focal_distance_ * scale);
      if (!std::isfinite(*c.focus_distance) || !(*c.focus_distance > 0.0f) ||
          !std::isfinite(c.aperture_radius)) {
        fail(camera_at_, "the lens (lensradius, focaldistance) is beyond float range");
      }
    }
    // Camera::look_at's right is cross(forward, up); pbrt's is the camera's +x.
    c.mirror_x = glm::dot(glm::cross(forward, up), right) < 0.0;
    if (orthographic_) {
      // pbrt-v4's default screen window spans [-1, 1] on the film's shorter side; camera-space
      // lengths become world lengths by the camera transform's scale along y.
      const double half_height = screen_half_height_.value_or(
          c.height <= c.width ? 1.0 : static_cast<double>(c.height) / c.width);
      const double scale = glm::length(dvec3(world_from_camera * glm::dvec4(0, 1, 0, 0)));
      c.ortho_half_height = static_cast<float>(half_height * scale);
      if (!std::isfinite(*c.ortho_half_height) || !(*c.ortho_half_height > 0.0f)) {
        fail(camera_at_, "the orthographic camera's view is beyond float range");
      }
    }
    // The field of view spans the shorter side; tritrace takes the vertical one.
    const double half = fov_ * std::numbers::pi / 360.0;
    c.vertical_fov_degrees =
        c.height <= c.width
            ? fov_
            : 360.0 / std::numbers::pi *
                  std::atan(std::tan(half) * static_cast<double>(c.height) / c.width);

    if (out_.scene.materials.empty()) current_material();
    add_soup(out_.scene.mesh, world_, path_);
    for (const Placed& p : placements_) {
      Affine a;
      a.linear = glm::mat3(glm::dmat3(p.m));
      a.translation = glm::vec3(p.m[3]);
      try {
        add_instance(out_.scene, p.prototype, a);
      } catch (const Error& e) {
        fail(p.at, "ObjectInstance: " + e.reason());
      }
    }
    for (const Warning& w : warnings_) {
      out_.warnings.push_back(w.where + ": warning: " + w.what +
                              (w.count > 1 ? " (" + std::to_string(w.count) + " times)" : ""));
    }
  }

  struct Placed {
    uint32_t prototype;
    dmat4 m;
    PbrtLocation at;
  };

  struct Saved {
    GraphicsState state;
    bool transform_only;
    PbrtLocation at;
  };

  PbrtOptions options_;
  std::string path_;
  fs::path main_dir_;
  LoadedScene out_;
  GraphicsState gs_;
  std::vector<Saved> stack_;
  std::map<std::string, dmat4> named_spaces_;
  bool in_world_ = false;
  dmat4 camera_from_world_{1.0};
  PbrtLocation camera_at_;
  double fov_ = kPbrtFov;
  float shape_alpha_ = 1.0f;                                // the current shape's "float alpha"
  std::map<std::pair<uint32_t, float>, uint32_t> blended_;  // (material, alpha) -> its blend
  bool orthographic_ = false;
  std::optional<double> screen_half_height_;  // from "screenwindow"
  double lens_radius_ = 0.0;
  double focal_distance_ = kPbrtFocalDistance;
  std::map<std::string, uint32_t> named_materials_;
  std::map<std::string, SpectrumTexture> spectrum_textures_;
  std::map<std::string, double> float_textures_;
  std::map<std::string, int32_t> texture_files_;
  size_t baked_texels_ = 0;  // by mix textures, at most kMaxBakedTexels
  std::map<std::tuple<int, float, float, float, bool>, uint32_t> emissive_;
  int default_material_ = -1;
  Soup world_;
  std::map<std::string, Soup> objects_;
  Soup* object_ = nullptr;
  std::string object_name_;
  std::map<std::pair<std::string, bool>, int64_t> prototype_of_;  // -1: an empty object
  std::vector<Placed> placements_;
  std::vector<Warning> warnings_;
};

}  // namespace

LoadedScene parse_pbrt_scene(std::string_view text, const std::string& path,
                             const PbrtOptions& options) {
  Interpreter interpreter(path, options);
  return interpreter.run(text, path);
}

LoadedScene load_pbrt_scene(const std::string& path, const PbrtOptions& options) {
  const std::string text = options.read_text ? options.read_text(path) : read_input_file(path);
  return parse_pbrt_scene(text, path, options);
}

}  // namespace tritrace
