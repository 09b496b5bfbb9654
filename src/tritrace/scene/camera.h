// The pinhole camera: a pose (origin and an orthonormal right/down/forward basis) and a focal
// length in pixels. Pixel (x, y) looks along right * (x - W/2) + down * (y - H/2) + forward * f,
// with integer W/2 and H/2 (the pixel corner, as the lab does); image rows grow downward.
#pragma once

#include <glm/geometric.hpp>
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

  // The ray through the image position (px, py), in pixels from the image's top-left corner: a
  // sample at (x + u, y + v) of pixel (x, y) looks along (x + u - W/2, y + v - H/2, f) in the
  // camera's frame. primary_ray(x, y) is the same through the pixel's corner, with the offsets
  // computed in integers as the lab does.
  Ray ray_through(float px, float py) const {
    const float dx = px - static_cast<float>(width_ / 2);
    const float dy = py - static_cast<float>(height_ / 2);
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
    const glm::vec3 d(right_.x * dx + down_.x * dy + forward_.x * focal_,
                      right_.y * dx + down_.y * dy + forward_.y * focal_,
                      right_.z * dx + down_.z * dy + forward_.z * focal_);
    Ray ray;
    ray.origin = position_;
    ray.dir = glm::normalize(d);
    return ray;
  }

 private:
  Camera(int width, int height, glm::vec3 position, glm::vec3 right, glm::vec3 down,
         glm::vec3 forward, float focal_px);

  int width_, height_;
  float focal_;
  glm::vec3 position_;
  glm::vec3 right_, down_, forward_;
};

}  // namespace tritrace
