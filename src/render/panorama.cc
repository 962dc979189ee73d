#include "src/render/panorama.h"

#include <algorithm>
#include <cmath>

#include "src/core/error.h"
#include "src/core/strings.h"
#include "src/render/sh.h"

namespace pano4d {
namespace {

// A point this close to the panorama's centre has no direction.
constexpr double kMinDistance = 1e-9;
// cos(theta) floor near the poles, where a row is a single point and any
// footprint covers the whole row.
constexpr double kMinCosTheta = 1e-6;

// Splats points with per-point angular radii into `image`.
void Splat(const EquirectProjection& proj,
           const std::vector<Eigen::Vector3f>& points,
           const std::vector<Eigen::Vector3f>& colors,
           const std::vector<double>& radii, PanoramaImage* image) {
  const int w = proj.width, h = proj.height;
  for (std::size_t n = 0; n < points.size(); ++n) {
    const Eigen::Vector3d p = points[n].cast<double>();
    const double distance = (p - proj.center).norm();
    if (!(distance > kMinDistance) || !std::isfinite(distance)) continue;
    const Eigen::Vector2d uv = proj.Project(p);
    const double theta = (0.5 - uv.y() / h) * M_PI;
    const double radius = radii[n];
    const auto write = [&](int column, int row) {
      const std::size_t i = static_cast<std::size_t>(row) * w + column;
      if (image->distance[i] == 0 || distance < image->distance[i]) {
        image->distance[i] = static_cast<float>(distance);
        for (int c = 0; c < 3; ++c) image->rgb[3 * i + c] = colors[n](c);
      }
    };
    const Eigen::Vector2i own = proj.Pixel(uv);
    write(own.x(), own.y());  // the point's own pixel, however small it is
    const int row0 =
        std::max(0, static_cast<int>(std::floor(uv.y() - radius / M_PI * h)));
    const int row1 = std::min(
        h - 1, static_cast<int>(std::floor(uv.y() + radius / M_PI * h)));
    for (int row = row0; row <= row1; ++row) {
      const double row_theta = (0.5 - (row + 0.5) / h) * M_PI;
      const double d_theta = row_theta - theta;
      if (std::abs(d_theta) > radius) continue;
      // Remaining angular half-width along the row, widened by 1/cos(theta)
      // because meridians converge towards the poles.
      const double half = std::sqrt(radius * radius - d_theta * d_theta) /
                          std::max(std::cos(row_theta), kMinCosTheta);
      const double half_px = std::min(half / (2 * M_PI) * w, w / 2.0);
      const int k0 = static_cast<int>(std::floor(uv.x() - half_px));
      const int k1 = static_cast<int>(std::floor(uv.x() + half_px));
      for (int k = k0; k <= std::min(k1, k0 + w - 1); ++k)
        write(((k % w) + w) % w, row);
    }
  }
}

PanoramaImage Blank(const EquirectProjection& proj) {
  if (proj.width <= 0 || proj.height <= 0) {
    throw Error("panorama", "size", SizeText(proj.width, proj.height),
                "must be positive");
  }
  PanoramaImage image;
  image.width = proj.width;
  image.height = proj.height;
  image.rgb.assign(static_cast<std::size_t>(proj.width) * proj.height * 3,
                   0.0f);
  image.distance.assign(static_cast<std::size_t>(proj.width) * proj.height,
                        0.0f);
  return image;
}

}  // namespace

Eigen::Vector2d EquirectProjection::Project(
    const Eigen::Vector3d& point) const {
  const Eigen::Vector3d q = r_align.transpose() * (point - center);
  const double phi = std::atan2(q.y(), q.x());
  const double theta = std::atan2(q.z(), std::hypot(q.x(), q.y()));
  return {(phi / (2 * M_PI) + 0.5) * width, (0.5 - theta / M_PI) * height};
}

Eigen::Vector3d EquirectProjection::Direction(const Eigen::Vector2d& uv) const {
  const double phi = (uv.x() / width - 0.5) * 2 * M_PI;
  const double theta = (0.5 - uv.y() / height) * M_PI;
  return r_align * Eigen::Vector3d(std::cos(theta) * std::cos(phi),
                                   std::cos(theta) * std::sin(phi),
                                   std::sin(theta));
}

Eigen::Vector2i EquirectProjection::Pixel(const Eigen::Vector2d& uv) const {
  const int column = static_cast<int>(std::floor(uv.x()));
  const int row = static_cast<int>(std::floor(uv.y()));
  return {((column % width) + width) % width, std::clamp(row, 0, height - 1)};
}

PanoramaImage SplatPoints(const EquirectProjection& projection,
                          const std::vector<Eigen::Vector3f>& points,
                          const std::vector<Eigen::Vector3f>& colors,
                          double angular_radius) {
  if (points.size() != colors.size()) {
    throw Error("panorama", "colors", std::to_string(colors.size()),
                "expected one colour per point (" +
                    std::to_string(points.size()) + ")");
  }
  PanoramaImage image = Blank(projection);
  Splat(projection, points, colors,
        std::vector<double>(points.size(), angular_radius), &image);
  return image;
}

PanoramaImage SplatGaussians(const EquirectProjection& projection,
                             const GaussianModel& model) {
  model.Check();
  const float c0 = static_cast<float>(kShC0);
  const int k_count = model.sh_coefficients();
  const double pixel_angle = 2 * M_PI / projection.width;
  std::vector<Eigen::Vector3f> points(model.size()), colors(model.size());
  std::vector<double> radii(model.size());
  for (std::size_t i = 0; i < model.size(); ++i) {
    points[i] = Eigen::Vector3f(model.means[3 * i], model.means[3 * i + 1],
                                model.means[3 * i + 2]);
    for (int c = 0; c < 3; ++c) {
      colors[i](c) = std::max(0.0f, c0 * model.sh[i * k_count * 3 + c] + 0.5f);
    }
    const double sigma =
        std::exp(std::max({model.log_scales[3 * i], model.log_scales[3 * i + 1],
                           model.log_scales[3 * i + 2]}));
    const double distance =
        (points[i].cast<double>() - projection.center).norm();
    const double radius =
        distance > kMinDistance ? 3 * sigma / distance : pixel_angle;
    radii[i] = std::clamp(std::isfinite(radius) ? radius : pixel_angle,
                          pixel_angle, M_PI);
  }
  PanoramaImage image = Blank(projection);
  Splat(projection, points, colors, radii, &image);
  return image;
}

}  // namespace pano4d
