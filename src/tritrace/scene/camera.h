// The camera: a pose (origin and an orthonormal right/down/forward basis) and a focal length in
// pixels. Pixel (x, y) looks along right * (x - W/2) + down * (y - H/2) + forward * f, with
// integer W/2 and H/2 (the pixel corner, as the lab does); image rows grow downward. Two settings
// change that pinhole: an orthographic projection (parallel rays, glTF's orthographic cameras) and
// a thin lens (depth of field, pbrt's lensradius/focaldistance).
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "tritrace/math/ray.h"

namespace tritrace {

class Camera {
 public:
  Camera() : Camera(500, 500) {}
  // The lab's orbit camera: at R_y(yaw) * (0, 0, -distance), looking at the origin, world y down.
  // focal_px <= 0 means the lab's default, f = height.
  Camera(int width, int height, double yaw = 0.0, float distance = 3.0f, float focal_px = 0.0f);

  // A camera at `position` looking at `target`; `up` is the world direction that appears upward
  // in the image (the lab's is (0, -1, 0), since its world y points down). The caller guarantees
  // position != target and up not parallel to the viewing direction (see is_valid_look_at).
  static Camera look_at(int width, int height, glm::vec3 position, glm::vec3 target, glm::vec3 up,
                        float focal_px);
  static bool is_valid_look_at(glm::vec3 position, glm::vec3 target, glm::vec3 up);

  // The focal length in pixels that gives an image `height` pixels tall a vertical field of view
  // of `degrees`.
  static float focal_for_vertical_fov(int height, double degrees);

  // The same camera (orientation, focal length, image size) at another position: how a scene
  // moved by a translation and uniform scale keeps its view (scene/transform.h).
  Camera with_position(glm::vec3 position) const {
    Camera moved = *this;
    moved.position_ = position;
    return moved;
  }

  // The same camera seen in a mirror: the image's x axis reversed (right negated), as pbrt's
  // left-handed camera space has it (CameraSpec::mirror_x).
  Camera mirrored_x() const {
    Camera mirrored = *this;
    mirrored.right_ = -right_;
    return mirrored;
  }

  // The same camera with a thin lens of radius `radius` (world units; 0: the pinhole) focused on
  // the plane `focus` (> 0) in front of it along forward (pbrt's lensradius and focaldistance).
  Camera with_lens(float radius, float focus) const {
    Camera lens = *this;
    lens.lens_radius_ = radius;
    lens.focus_distance_ = focus;
    return lens;
  }

  // The same pose as an orthographic camera: every ray leaves the image plane along forward, from
  // right * (x - W/2) * s + down * (y - H/2) * s, with s = `world_per_pixel` (> 0); the focal
  // length no longer matters.
  Camera orthographic(float world_per_pixel) const {
    Camera ortho = *this;
    ortho.ortho_scale_ = world_per_pixel;
    return ortho;
  }

  // The rays through the pixels [x0, x1) x [y0, y1), row by row, into out[0, (x1-x0)*(y1-y0)):
  // the same bits as primary_ray (tested), simd::kLanes pixels at a time where the build has SIMD.
  void primary_rays(int x0, int y0, int x1, int y1, Ray* out) const;

  int width() const { return width_; }
  int height() const { return height_; }
  float focal_px() const { return focal_; }
  glm::vec3 position() const { return position_; }
  glm::vec3 right() const { return right_; }
  glm::vec3 down() const { return down_; }
  glm::vec3 forward() const { return forward_; }
  bool has_lens() const { return lens_radius_ > 0.0f; }
  float lens_radius() const { return lens_radius_; }
  float focus_distance() const { return focus_distance_; }
  bool is_orthographic() const { return ortho_scale_ > 0.0f; }
  float ortho_scale() const { return ortho_scale_; }

  // The ray through the image position (px, py), in pixels from the image's top-left corner: a
  // sample at (x + u, y + v) of pixel (x, y) looks along (x + u - W/2, y + v - H/2, f) in the
  // camera's frame. primary_ray(x, y) is the same through the pixel's corner, with the offsets
  // computed in integers as the lab does.
  Ray ray_through(float px, float py) const {
    const float dx = px - static_cast<float>(width_ / 2);
    const float dy = py - static_cast<float>(height_ / 2);
    if (ortho_scale_ > 0.0f) return orthographic_ray(dx, dy);
    const glm::vec3 d(right_.x * dx + down_.x * dy + forward_.x * focal_,
                      right_.y * dx + down_.y * dy + forward_.y * focal_,
                      right_.z * dx + down_.z * dy + forward_.z * focal_);
    Ray ray;
    ray.origin = position_;
    ray.dir = glm::normalize(d);
    return ray;
  }

  // The ray through pixel (x, y); its direction is normalised, so t is a distance. Inline: the
  // renderer calls it once per pixel.
  Ray primary_ray(int x, int y) const {
    // The lab's integer halves: the pixel corner, not its centre.
    const int half_width = width_ / 2, half_height = height_ / 2;
    const float dx = static_cast<float>(x - half_width);
    const float dy = static_cast<float>(y - half_height);
    if (ortho_scale_ > 0.0f) return orthographic_ray(dx, dy);
    const glm::vec3 d(right_.x * dx + down_.x * dy + forward_.x * focal_,
                      right_.y * dx + down_.y * dy + forward_.y * focal_,
                      right_.z * dx + down_.z * dy + forward_.z * focal_);
    Ray ray;
    ray.origin = position_;
    ray.dir = glm::normalize(d);
    return ray;
  }

  // The thin-lens ray through the image position (px, py) for the lens sample u in [0, 1)^2: from
  // a point of the lens disk (Shirley and Chiu's concentric map, so stratified u stay stratified on
  // the disk) towards where the pinhole ray through (px, py) meets the plane in focus (pbrt-v4's
  // PerspectiveCamera and OrthographicCamera do the same). Points on that plane stay sharp; a
  // point at depth d is spread over a disk of diameter 2 R |d - focus| / d in the focus plane.
  // Without a lens, ray_through(px, py) exactly. Out of line: only lensed renders call it.
  Ray lens_ray(float px, float py, glm::vec2 u) const;

 private:
  // The orthographic ray at offsets (dx, dy) pixels from the image centre.
  Ray orthographic_ray(float dx, float dy) const {
    Ray ray;
    ray.origin = position_ + right_ * (dx * ortho_scale_) + down_ * (dy * ortho_scale_);
    ray.dir = forward_;
    return ray;
  }

  Camera(int width, int height, glm::vec3 position, glm::vec3 right, glm::vec3 down,
         glm::vec3 forward, float focal_px);

  int width_, height_;
  float focal_;
  glm::vec3 position_;
  glm::vec3 right_, down_, forward_;
  float lens_radius_ = 0.0f;     // 0: a pinhole
  float focus_distance_ = 1.0f;  // along forward; only read with a lens
  float ortho_scale_ = 0.0f;     // world units per pixel; 0: perspective
};

}  // namespace tritrace
