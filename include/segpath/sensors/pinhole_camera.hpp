// A pinhole camera with a box pixel filter, modelling Sensor: W_rho(s_1) for each pixel
// (N17, N22), sensor-start rays (N29) and the direction -> pixel map light tracing needs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "segpath/concepts/sensor.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/in_place_optional.hpp"

namespace segpath {

/// What a PinholeCamera is built from. The frame (forward F, right R, up U) must be
/// orthonormal (to 1e-5); it need not be right-handed. The image has `width` x `height`
/// pixels, row 0 at the top, pixel index y * width + x; `fov_x_degrees` and `fov_y_degrees`
/// are the full horizontal and vertical fields of view, in (0, 180).
template <Real T>
struct PinholeCameraParameters {
  Vec3<T> position{0, 0, 0};
  Vec3<T> forward{0, 1, 0};
  Vec3<T> right{1, 0, 0};
  Vec3<T> up{0, 0, 1};
  std::uint32_t width = 1;
  std::uint32_t height = 1;
  T fov_x_degrees = 45;
  T fov_y_degrees = 45;
};

/// A pinhole at `position` (a PointKind::point sensor end). With t_x = tan(fov_x / 2) and
/// t_y = tan(fov_y / 2), raster point (r_x, r_y) in [0, W) x [0, H) is the image-plane point
/// F + (2 r_x / W - 1) t_x R + (1 - 2 r_y / H) t_y U at distance 1, and pixel (x, y) covers
/// r in [x, x + 1) x [y, y + 1) (the cornell-boxes.md camera).
///
/// sample_ray(pixel, u_direction = (u, v)): the direction through raster point (x + u, y + v),
/// uniform in image-plane area over the pixel; pdf_position = 1 (the pinhole), pdf_direction
/// its solid-angle density 1 / (A_pixel cos^3 theta) (dA = d^2 d omega / cos theta with
/// d = 1 / cos theta, A_pixel = 4 t_x t_y / (W H) and cos theta = w . F).
/// importance = W_rho(w) = 1 / (A_pixel cos^3 theta) inside pixel rho and 0 outside, with
/// cos_x = 1 folded in (a `point` origin), so W cos_x / (pdf_position pdf_direction) = 1 for
/// every sampled ray and the integral of W_rho over directions is 1: a pixel's value is the
/// mean radiance over its image-plane area (box filter). u_position is unused.
template <Real T>
class PinholeCamera {
 public:
  /// Throws std::invalid_argument for a non-finite position, a frame that is not
  /// orthonormal, a zero width or height (or more than 2^32 - 2 pixels), or a field of view
  /// outside (0, 180) degrees.
  explicit PinholeCamera(const PinholeCameraParameters<T>& p)
      : position_(p.position),
        forward_(p.forward),
        right_(p.right),
        up_(p.up),
        width_(p.width),
        height_(p.height) {
    if (!is_finite(p.position))
      throw std::invalid_argument("segpath::PinholeCamera: position must be finite");
    const T tolerance = T(1e-5);
    const auto unit = [&](const Vec3<T>& v, const char* name) {
      const T len = glm::length(v);
      if (!is_finite(v) || !(std::abs(len - T(1)) <= tolerance))
        throw std::invalid_argument(std::string("segpath::PinholeCamera: ") + name +
                                    " must be a unit vector, its length is " + format_number(double(len)));
    };
    unit(forward_, "forward");
    unit(right_, "right");
    unit(up_, "up");
    const auto orthogonal = [&](const Vec3<T>& a, const Vec3<T>& b, const char* names) {
      const T c = glm::dot(a, b);
      if (!(std::abs(c) <= tolerance))
        throw std::invalid_argument(std::string("segpath::PinholeCamera: ") + names +
                                    " must be orthogonal, their dot product is " +
                                    format_number(double(c)));
    };
    orthogonal(forward_, right_, "forward and right");
    orthogonal(forward_, up_, "forward and up");
    orthogonal(right_, up_, "right and up");
    if (width_ == 0 || height_ == 0)
      throw std::invalid_argument(
          "segpath::PinholeCamera: the resolution must be at least 1 x 1, got " +
          std::to_string(width_) + " x " + std::to_string(height_));
    if (static_cast<std::uint64_t>(width_) * height_ >= std::numeric_limits<std::uint32_t>::max())
      throw std::invalid_argument("segpath::PinholeCamera: too many pixels (" +
                                  std::to_string(width_) + " x " + std::to_string(height_) + ")");
    const auto half_tan = [](T fov, const char* name) {
      if (!(fov > T(0) && fov < T(180)))
        throw std::invalid_argument(std::string("segpath::PinholeCamera: ") + name +
                                    " must lie in (0, 180) degrees, got " + format_number(double(fov)));
      return static_cast<T>(std::tan(static_cast<double>(fov) * std::numbers::pi / 360.0));
    };
    tan_x_ = half_tan(p.fov_x_degrees, "fov_x_degrees");
    tan_y_ = half_tan(p.fov_y_degrees, "fov_y_degrees");
    inv_pixel_area_ =
        static_cast<T>(static_cast<double>(width_) * static_cast<double>(height_) /
                       (4.0 * static_cast<double>(tan_x_) * static_cast<double>(tan_y_)));
    // A field of view so narrow that a pixel's area on the image plane is 0 in T: every ray's
    // density would be infinite (a black image with nothing dropped).
    if (!(tan_x_ > T(0) && tan_y_ > T(0)) || !std::isfinite(inv_pixel_area_))
      throw std::invalid_argument("segpath::PinholeCamera: the field of view (" + format_number(double(p.fov_x_degrees)) + " x " +
                                  format_number(double(p.fov_y_degrees)) + " degrees) is too narrow for " +
                                  std::to_string(width_) + " x " + std::to_string(height_) + " pixels in this scalar type");
    forward_ = glm::normalize(forward_);
    right_ = glm::normalize(right_);
    up_ = glm::normalize(up_);
    point_ = SurfacePoint<T>::at_point(position_, forward_);
  }

  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return width_ * height_; }
  [[nodiscard]] std::uint32_t width() const noexcept { return width_; }
  [[nodiscard]] std::uint32_t height() const noexcept { return height_; }
  [[nodiscard]] const Vec3<T>& position() const noexcept { return position_; }
  [[nodiscard]] const Vec3<T>& forward() const noexcept { return forward_; }
  [[nodiscard]] const Vec3<T>& right() const noexcept { return right_; }
  [[nodiscard]] const Vec3<T>& up() const noexcept { return up_; }
  /// tan(fov_x / 2) and tan(fov_y / 2).
  [[nodiscard]] T tan_half_fov_x() const noexcept { return tan_x_; }
  [[nodiscard]] T tan_half_fov_y() const noexcept { return tan_y_; }
  /// 1 / A_pixel: the inverse image-plane area of one pixel at distance 1.
  [[nodiscard]] T inverse_pixel_area() const noexcept { return inv_pixel_area_; }
  /// The sensor end x_1 (PointKind::point at the pinhole, reference axis F).
  [[nodiscard]] const SurfacePoint<T>& point() const noexcept { return point_; }

  /// The unit direction through raster point (r_x, r_y) (not checked against the image).
  [[nodiscard]] Vec3<T> direction_through(const Vec2<T>& raster) const noexcept {
    const T sx = T(2) * raster.x / T(width_) - T(1);
    const T sy = T(1) - T(2) * raster.y / T(height_);
    return glm::normalize(forward_ + right_ * (sx * tan_x_) + up_ * (sy * tan_y_));
  }

  /// The raster point a direction from the pinhole passes through; nullopt behind the camera
  /// (w . F <= 0), outside [0, W) x [0, H), or for a non-finite direction. Light tracing uses
  /// it (through importance()) to find the pixel of a connection to the camera.
  [[nodiscard]] std::optional<Vec2<T>> raster_position(const Vec3<T>& direction) const noexcept {
    const T cz = glm::dot(direction, forward_);
    if (!(cz > T(0))) return std::nullopt;
    const T sx = glm::dot(direction, right_) / (cz * tan_x_);
    const T sy = glm::dot(direction, up_) / (cz * tan_y_);
    const Vec2<T> r((sx + T(1)) * T(0.5) * T(width_), (T(1) - sy) * T(0.5) * T(height_));
    if (!(r.x >= T(0) && r.x < T(width_) && r.y >= T(0) && r.y < T(height_))) return std::nullopt;
    return r;
  }

  /// The solid-angle density 1 / (A_pixel cos^3 theta) of a unit direction w in front of the
  /// camera (0 behind it); it is also W_rho(w) for the pixel w falls in.
  [[nodiscard]] T direction_density(const Vec3<T>& direction) const noexcept {
    const T c = glm::dot(direction, forward_);
    if (!(c > T(0))) return T(0);
    const T density = inv_pixel_area_ / (c * c * c);
    return std::isfinite(density) ? density : T(0);
  }

  /// The ray through raster point (x + u, y + v) of pixel (x, y); nullopt for a pixel index
  /// >= pixel_count().
  [[nodiscard]] std::optional<SensorSample<T>> sample_ray(
      const SensorSampleQuery<T>& q) const noexcept {
    if (q.pixel >= pixel_count()) return std::nullopt;
    const std::uint32_t x = q.pixel % width_;
    const std::uint32_t y = q.pixel / width_;
    // Keep the raster point inside the pixel when x + u rounds up to x + 1 (float, large x);
    // nextafter, a libm call, only then.
    const auto inside = [](T r, std::uint32_t end) { return r < T(end) ? r : std::min(r, std::nextafter(T(end), T(0))); };
    const Vec2<T> raster(inside(T(x) + q.u_direction.x, x + 1), inside(T(y) + q.u_direction.y, y + 1));
    const Vec3<T> w = direction_through(raster);
    const T density = direction_density(w);
    if (!(density > T(0))) return std::nullopt;
    return in_place_optional<SensorSample<T>>(point(), w, density, T(1), density);
  }

  /// The pixel a ray from the pinhole falls in and W_rho = direction_density(w); nullopt for
  /// an origin other than point() (a delta position matches only itself) or a direction
  /// outside the image.
  [[nodiscard]] std::optional<SensorResponse<T>> importance(
      const SensorQuery<T>& q) const noexcept {
    if (!is_own_point(q.origin)) return std::nullopt;
    const auto r = raster_position(q.direction);
    if (!r) return std::nullopt;
    const T w = direction_density(q.direction);
    if (!(w > T(0))) return std::nullopt;
    const auto x = std::min(static_cast<std::uint32_t>(r->x), width_ - 1);
    const auto y = std::min(static_cast<std::uint32_t>(r->y), height_ - 1);
    return in_place_optional<SensorResponse<T>>(y * width_ + x, w);
  }

  /// {1, direction_density(w)} for a ray from the pinhole into the image, {0, 0} otherwise.
  [[nodiscard]] SensorPdf<T> pdf(const SensorQuery<T>& q) const noexcept {
    if (!is_own_point(q.origin) || !raster_position(q.direction)) return SensorPdf<T>{};
    return SensorPdf<T>{T(1), direction_density(q.direction)};
  }

 private:
  [[nodiscard]] bool is_own_point(const SurfacePoint<T>& p) const noexcept {
    return p.kind == PointKind::point && p.position == position_;
  }

  Vec3<T> position_;
  Vec3<T> forward_, right_, up_;
  /// point()'s value, kept whole: a sample copies it from here, not from a point just built on the stack.
  SurfacePoint<T> point_;
  std::uint32_t width_, height_;
  T tan_x_ = 1, tan_y_ = 1;
  T inv_pixel_area_ = 1;
};

/// The camera of the four cornell boxes (cornell-boxes.md): pinhole at
/// (-0.0439815, -4.12529, 0.222539), its forward/right/up frame, 45 degrees horizontal field
/// of view and square pixels (so 45 degrees vertically too at the reference 512 x 512, as in
/// SmallVCM, whose camera fixes the horizontal angle).
template <Real T>
[[nodiscard]] PinholeCamera<T> cornell_camera(std::uint32_t width = 512,
                                              std::uint32_t height = 512) {
  PinholeCameraParameters<T> p;
  p.position = Vec3<T>(T(-0.0439815), T(-4.12529), T(0.222539));
  p.forward = Vec3<T>(T(0.006886253), T(0.9985055), T(-0.05421613));
  p.right = Vec3<T>(T(0.9999762), T(-0.006896396), T(0));
  p.up = Vec3<T>(T(0.0003738963), T(0.05421484), T(0.9985293));
  p.width = width;
  p.height = height;
  p.fov_x_degrees = T(45);
  if (width == height || width == 0 || height == 0) {
    p.fov_y_degrees = T(45);
  } else {
    const double tan_y =
        std::tan(std::numbers::pi / 8.0) * static_cast<double>(height) / static_cast<double>(width);
    p.fov_y_degrees = static_cast<T>(std::atan(tan_y) * 360.0 / std::numbers::pi);
  }
  return PinholeCamera<T>(p);
}

}  // namespace segpath
