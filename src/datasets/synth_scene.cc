#include "src/datasets/synth_scene.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/error.h"

namespace pano4d::synth {
namespace {

// Hits closer than this along a ray are ignored: a ray starting on a
// surface must not hit that surface again through rounding.
constexpr double kMinHitDistance = 1e-6;
// Below this bend angle the tube is straight (avoids L / beta at beta = 0).
constexpr double kStraightBend = 1e-9;

Eigen::Quaterniond Yaw(double angle) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()));
}

double Ease(double s) { return s * s * (3 - 2 * s); }

Rigid3d Pose(const Part& part, double s) {
  switch (part.motion) {
    case MotionKind::kStatic:
      return part.rest;
    case MotionKind::kSlide: {
      const double e = Ease(s);
      return Rigid3d(Yaw(part.amplitude * e) * part.rest.rotation,
                     part.from + (part.to - part.from) * e);
    }
    case MotionKind::kBounce: {
      const Eigen::Vector3d path = part.to - part.from;
      const double radius = part.half_size.x();
      Eigen::Vector3d position = part.from + path * s;
      position.z() +=
          part.amplitude * std::abs(std::sin(M_PI * part.frequency * s));
      // Rolls along its path: angle = distance / radius about z x path.
      const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(path);
      const double norm = axis.norm();
      const Eigen::Quaterniond roll =
          norm > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(
                         path.norm() * s / radius, axis / norm))
                   : Eigen::Quaterniond::Identity();
      return Rigid3d(roll * part.rest.rotation, position);
    }
    case MotionKind::kBend: {
      // The tube's centreline is a circular arc of length L in the tube
      // frame's x-z plane, bent by beta(s); the part sits at arc length u L,
      // turned with the arc's tangent.
      const double beta =
          part.amplitude * std::sin(2 * M_PI * part.frequency * s + part.phase);
      const double a = beta * part.u;
      const Eigen::Vector3d center =
          std::abs(beta) < kStraightBend
              ? Eigen::Vector3d(0, 0, part.length * part.u)
              : Eigen::Vector3d(part.length / beta * (1 - std::cos(a)), 0,
                                part.length / beta * std::sin(a));
      const Eigen::Quaterniond turn(
          Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()));
      return Rigid3d(part.rest.rotation * turn,
                     part.from + part.rest.rotation * center);
    }
  }
  return part.rest;
}

Material RandomMaterial(std::mt19937& rng, const Eigen::Vector3d& hue,
                        int pattern, double frequency) {
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  Material m;
  m.color_a = (hue + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng)))
                  .cwiseMax(0.05)
                  .cwiseMin(0.95);
  m.color_b = (0.45 * m.color_a +
               Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng)))
                  .cwiseMax(0.02)
                  .cwiseMin(0.9);
  m.mark_color = 0.15 * m.color_b;
  m.frequency = frequency;
  m.mark_frequency =
      4.0 + 4.0 * std::uniform_real_distribution<double>(0, 1)(rng);
  m.mark_density =
      0.3 + 0.2 * std::uniform_real_distribution<double>(0, 1)(rng);
  m.pattern = pattern;
  m.seed = static_cast<std::uint32_t>(rng());
  return m;
}

bool IntersectSphere(double radius, const Eigen::Vector3d& o,
                     const Eigen::Vector3d& d, double* t) {
  const double b = o.dot(d);
  const double c = o.squaredNorm() - radius * radius;
  const double disc = b * b - c;
  if (disc < 0) return false;
  const double root = std::sqrt(disc);
  double hit = -b - root;
  if (hit <= kMinHitDistance)
    hit = -b + root;  // inside the sphere: its far side
  if (hit <= kMinHitDistance) return false;
  *t = hit;
  return true;
}

// Slab test. Outside a box: the entry; inside (the room): the exit.
bool IntersectBox(const Eigen::Vector3d& half, bool inside,
                  const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* t,
                  int* axis, int* face) {
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int near_axis = 0, far_axis = 0;
  for (int a = 0; a < 3; ++a) {
    const double inv = 1.0 / d(a);
    double t0 = (-half(a) - o(a)) * inv;
    double t1 = (half(a) - o(a)) * inv;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      near_axis = a;
    }
    if (t1 < t_far) {
      t_far = t1;
      far_axis = a;
    }
  }
  if (t_near > t_far) return false;
  if (inside) {
    if (t_far <= kMinHitDistance) return false;
    *t = t_far;
    *axis = far_axis;
    *face = 2 * far_axis + (d(far_axis) > 0 ? 1 : 0);
  } else {
    if (t_near <= kMinHitDistance) return false;
    *t = t_near;
    *axis = near_axis;
    *face = 2 * near_axis + (d(near_axis) > 0 ? 0 : 1);
  }
  return true;
}

}  // namespace

bool Layout::IsDefault() const { return ToJson() == Layout().ToJson(); }

nlohmann::json Layout::ToJson() const {
  nlohmann::json j{
      {"training_half_sweep_degrees", training_half_sweep_degrees},
      {"training_height", training_height},
      {"training_radius", training_radius},
      {"validation_azimuth_degrees",
       {validation_azimuth_degrees[0], validation_azimuth_degrees[1]}},
      {"validation_height", {validation_height[0], validation_height[1]}},
      {"validation_radius", {validation_radius[0], validation_radius[1]}},
      {"dynamic_scale", dynamic_scale},
      {"texture_frequency_scale", texture_frequency_scale},
      {"near_object_camera", near_object_camera}};
  if (near_object_camera != 0) {
    j["near_object_distance"] = near_object_distance;
    j["near_object"] = near_object_is_sphere ? "sphere" : "box";
    j["near_object_size"] = near_object_size;
  }
  return j;
}

Layout VariedLayout(std::uint32_t seed) {
  // Its own generator, so that the scene's jitter draws stay as they are.
  std::mt19937 rng(seed * 2246822519U + 0x5eed);
  const auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  Layout l;
  l.training_half_sweep_degrees = uniform(15.0, 35.0);
  l.training_height = uniform(1.1, 1.9);
  l.training_radius = uniform(2.5, 3.0);
  // One camera on each side of the arc, or (one scene in four) both on the
  // same side, the second 20-45 degrees past the first (at most 110).
  const bool same_side = uniform(0, 1) < 0.25;
  const double first = uniform(40.0, 85.0), second = uniform(40.0, 85.0);
  l.validation_azimuth_degrees[0] = first;
  l.validation_azimuth_degrees[1] =
      same_side ? std::min(first + 20.0 + (second - 40.0) * 25.0 / 45.0, 110.0)
                : -second;
  for (int i = 0; i < 2; ++i) {
    l.validation_height[i] = uniform(0.6, 2.4);
    l.validation_radius[i] = uniform(2.0, 3.0);
  }
  l.dynamic_scale = uniform(0.7, 1.5);
  l.texture_frequency_scale = std::exp(uniform(std::log(0.5), std::log(2.5)));
  if (uniform(0, 1) < 0.8) {
    l.near_object_camera = uniform(0, 1) < 0.5 ? 1 : 2;
    l.near_object_distance = uniform(0.7, 1.3);
    l.near_object_is_sphere = uniform(0, 1) < 0.5;
    l.near_object_size = uniform(0.12, 0.3);
  }
  return l;
}

Eigen::Vector3d ValidationEye(const Scene& scene, int index) {
  if (index != 1 && index != 2) {
    throw Error("synth camera", "index", std::to_string(index),
                "validation cameras are 1 and 2");
  }
  constexpr double kArcMiddle = -90.0;  // degrees, the -y side
  const Layout& l = scene.layout;
  const double azimuth =
      (kArcMiddle + l.validation_azimuth_degrees[index - 1]) * (M_PI / 180.0);
  const double radius = l.validation_radius[index - 1];
  return Eigen::Vector3d(scene.target.x() + radius * std::cos(azimuth),
                         scene.target.y() + radius * std::sin(azimuth),
                         l.validation_height[index - 1]);
}

namespace {

// BuildScene's parts, added in a fixed order from one generator: the same
// seed gives the same scene.
class SceneBuilder {
 public:
  SceneBuilder(std::uint32_t seed, const Layout& layout)
      : rng_(seed * 2654435761U + 12345U),
        texture_(layout.texture_frequency_scale) {
    scene_.layout = layout;
    scene_.room_min = Eigen::Vector3d(-4, -3, 0);
    scene_.room_max = Eigen::Vector3d(4, 3, 3);
    scene_.target = Eigen::Vector3d(0.1, 0.8, 0.6);
    scene_.light_directions = {Eigen::Vector3d(0.4, -0.3, 0.85).normalized(),
                               Eigen::Vector3d(-0.5, 0.6, 0.4).normalized()};
    scene_.light_intensities = {0.75, 0.35};
    scene_.ambient = 0.3;
  }

  void AddRoom();
  void AddFurniture();
  void AddRigidMovers(double k);
  void AddTube(double k);
  void AddNearObject();
  Scene Finish(bool is_static);

 private:
  double Jitter(double amount) { return amount * (2 * unit_(rng_) - 1); }
  // Returns the new part's index (a reference would dangle on the next add).
  std::size_t Add(ShapeKind shape, const Eigen::Vector3d& half,
                  const Eigen::Vector3d& at, double yaw,
                  const Eigen::Vector3d& hue, int pattern);

  Scene scene_;
  std::mt19937 rng_;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  double texture_;
  int next_instance_ = 2;
};

std::size_t SceneBuilder::Add(ShapeKind shape, const Eigen::Vector3d& half,
                              const Eigen::Vector3d& at, double yaw,
                              const Eigen::Vector3d& hue, int pattern) {
  Part part;
  part.shape = shape;
  part.half_size = half;
  part.rest = Rigid3d(Yaw(yaw), at);
  part.instance = next_instance_++;
  part.material = static_cast<int>(scene_.materials.size());
  scene_.materials.push_back(
      RandomMaterial(rng_, hue, pattern, 4.0 * texture_));
  scene_.parts.push_back(part);
  return scene_.parts.size() - 1;
}

// Floor, four walls, ceiling, each its own material.
void SceneBuilder::AddRoom() {
  const std::vector<std::pair<Eigen::Vector3d, int>> room_looks = {
      {{0.75, 0.45, 0.35}, 2}, {{0.35, 0.55, 0.75}, 0}, {{0.8, 0.75, 0.5}, 1},
      {{0.45, 0.7, 0.45}, 0},  {{0.6, 0.45, 0.3}, 1},   {{0.85, 0.85, 0.8}, 0}};
  Part room;
  room.shape = ShapeKind::kRoom;
  room.half_size = (scene_.room_max - scene_.room_min) / 2;
  room.rest = Rigid3d(Eigen::Quaterniond::Identity(),
                      (scene_.room_max + scene_.room_min) / 2);
  room.instance = 1;
  room.material = static_cast<int>(scene_.materials.size());
  for (const auto& [hue, pattern] : room_looks) {
    scene_.materials.push_back(
        RandomMaterial(rng_, hue, pattern, 1.5 * texture_));
  }
  scene_.parts.push_back(room);
}

void SceneBuilder::AddFurniture() {
  Add(ShapeKind::kBox, {0.55, 0.35, 0.37},
      {-1.5 + Jitter(0.15), 1.4 + Jitter(0.15), 0.37}, 0.3 + Jitter(0.2),
      {0.55, 0.35, 0.2}, 1);
  Add(ShapeKind::kBox, {0.25, 0.25, 0.25},
      {1.4 + Jitter(0.15), 1.6 + Jitter(0.15), 0.25}, Jitter(0.5),
      {0.8, 0.6, 0.3}, 2);
  Add(ShapeKind::kSphere, {0.3, 0.3, 0.3},
      {-0.4 + Jitter(0.1), 2.1 + Jitter(0.1), 0.3}, 0, {0.3, 0.6, 0.8}, 0);
  Add(ShapeKind::kBox, {0.15, 0.15, 0.9},
      {0.6 + Jitter(0.1), 2.4 + Jitter(0.1), 0.9}, Jitter(0.3),
      {0.7, 0.7, 0.72}, 1);
}

// A box sliding and turning, a ball bouncing and rolling; `k` scales them.
void SceneBuilder::AddRigidMovers(double k) {
  Part& slider =
      scene_.parts[Add(ShapeKind::kBox, Eigen::Vector3d::Constant(0.2 * k),
                       {-0.9, 0.3, 0.2 * k}, 0.0, {0.85, 0.3, 0.3}, 2)];
  slider.motion = MotionKind::kSlide;
  slider.from = Eigen::Vector3d(-0.9 + Jitter(0.1), 0.3 + Jitter(0.1), 0.2 * k);
  slider.to = Eigen::Vector3d(0.4 + Jitter(0.1), 0.0 + Jitter(0.1), 0.2 * k);
  slider.amplitude = M_PI / 2;
  Part& ball =
      scene_.parts[Add(ShapeKind::kSphere, Eigen::Vector3d::Constant(0.18 * k),
                       {0.9, 1.0, 0.18 * k}, 0, {0.9, 0.8, 0.2}, 0)];
  ball.motion = MotionKind::kBounce;
  ball.from = Eigen::Vector3d(1.0 + Jitter(0.1), 1.0 + Jitter(0.1), 0.18 * k);
  ball.to = Eigen::Vector3d(0.1 + Jitter(0.1), 0.6 + Jitter(0.1), 0.18 * k);
  ball.amplitude = 0.5;
  ball.frequency = 2.0;
}

// Non-rigid: a tube bending back and forth, a chain of overlapping spheres
// along an arc whose curvature changes; the texture is painted in the
// straight pose (offset by arc length) and deforms with the bend.
void SceneBuilder::AddTube(double k) {
  constexpr int kTubeSpheres = 16;
  const double length = 1.3 * k, base_radius = 0.11 * k;
  const Eigen::Vector3d base(1.3 + Jitter(0.1), 0.2 + Jitter(0.1), 0.0);
  const double tube_yaw = 0.6 + Jitter(0.2);
  const int tube_instance = next_instance_++;
  const int tube_material = static_cast<int>(scene_.materials.size());
  scene_.materials.push_back(
      RandomMaterial(rng_, {0.35, 0.75, 0.35}, 1, 5.0 * texture_));
  for (int i = 0; i < kTubeSpheres; ++i) {
    Part part;
    part.shape = ShapeKind::kSphere;
    part.u = (i + 0.5) / kTubeSpheres;
    const double radius = base_radius * (1.0 - 0.4 * part.u);
    part.half_size = Eigen::Vector3d::Constant(radius);
    part.instance = tube_instance;
    part.material = tube_material;
    part.texture_offset = Eigen::Vector3d(0, 0, length * part.u);
    part.motion = MotionKind::kBend;
    part.rest = Rigid3d(Yaw(tube_yaw), Eigen::Vector3d::Zero());
    part.from = base;
    part.length = length;
    part.amplitude = 0.9;
    part.frequency = 1.0;
    part.phase = 0.4;
    scene_.parts.push_back(part);
  }
}

// Close to a validation camera: what a view far from the training arc sees
// large in front of everything else. Standing on the floor, its top at the
// camera's height at most, so that it fills the lower part of the view
// rather than all of it.
void SceneBuilder::AddNearObject() {
  const Layout& layout = scene_.layout;
  if (layout.near_object_camera == 0) return;
  const Eigen::Vector3d eye = ValidationEye(scene_, layout.near_object_camera);
  Eigen::Vector3d at =
      eye + (scene_.target - eye).normalized() * layout.near_object_distance;
  const double size = layout.near_object_size;
  const double height =
      layout.near_object_is_sphere ? size : std::max(size, 0.5 * at.z());
  at.z() = height;
  Add(layout.near_object_is_sphere ? ShapeKind::kSphere : ShapeKind::kBox,
      layout.near_object_is_sphere ? Eigen::Vector3d::Constant(size)
                                   : Eigen::Vector3d(size, size, height),
      at, Jitter(0.5), {0.5 + Jitter(0.3), 0.4 + Jitter(0.3), 0.6}, 2);
}

// A static scene's movers frozen where they are a third of the way through
// the clip.
Scene SceneBuilder::Finish(bool is_static) {
  for (Part& part : scene_.parts) {
    part.dynamic = !is_static && part.motion != MotionKind::kStatic;
    if (is_static && part.motion != MotionKind::kStatic) {
      part.rest = Pose(part, 1.0 / 3.0);
      part.motion = MotionKind::kStatic;
    }
  }
  return std::move(scene_);
}

}  // namespace

Scene BuildScene(std::uint32_t seed, bool is_static, double dynamic_scale,
                 const Layout& layout) {
  const double k = dynamic_scale * layout.dynamic_scale;
  SceneBuilder builder(seed, layout);
  builder.AddRoom();
  builder.AddFurniture();
  builder.AddRigidMovers(k);
  builder.AddTube(k);
  builder.AddNearObject();
  return builder.Finish(is_static);
}

PartPoses PosesAt(const Scene& scene, double s) {
  PartPoses poses;
  poses.world_from_part.reserve(scene.parts.size());
  poses.part_from_world.reserve(scene.parts.size());
  for (const Part& part : scene.parts) {
    poses.world_from_part.push_back(Pose(part, s));
    poses.part_from_world.push_back(poses.world_from_part.back().Inverse());
  }
  return poses;
}

Hit Intersect(const Scene& scene, const PartPoses& poses,
              const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  Hit best;
  for (std::size_t i = 0; i < scene.parts.size(); ++i) {
    const Part& part = scene.parts[i];
    const Rigid3d& to_part = poses.part_from_world[i];
    const Eigen::Vector3d o = to_part * origin;
    const Eigen::Vector3d d = to_part.rotation * direction;
    double t = 0;
    int axis = 0, face = 0;
    Eigen::Vector3d normal_local;
    if (part.shape == ShapeKind::kSphere) {
      if (!IntersectSphere(part.half_size.x(), o, d, &t) || t >= best.distance)
        continue;
      normal_local = (o + t * d) / part.half_size.x();
    } else {
      const bool inside = part.shape == ShapeKind::kRoom;
      if (!IntersectBox(part.half_size, inside, o, d, &t, &axis, &face) ||
          t >= best.distance) {
        continue;
      }
      normal_local = Eigen::Vector3d::Zero();
      normal_local(axis) = d(axis) > 0 ? -1.0 : 1.0;
    }
    best.distance = t;
    best.part = static_cast<int>(i);
    best.face = face;
    best.local = o + t * d;
    best.normal = poses.world_from_part[i].rotation * normal_local;
  }
  if (best.valid() && best.normal.dot(direction) > 0)
    best.normal = -best.normal;
  return best;
}

Eigen::Vector3d Shade(const Scene& scene, const Hit& hit) {
  const Part& part = scene.parts[hit.part];
  const int material =
      part.material + (part.shape == ShapeKind::kRoom ? hit.face : 0);
  const Eigen::Vector3d albedo =
      Albedo(scene.materials[material], hit.local + part.texture_offset);
  double light = scene.ambient;
  for (std::size_t k = 0; k < scene.light_directions.size(); ++k) {
    light += scene.light_intensities[k] *
             std::max(0.0, hit.normal.dot(scene.light_directions[k]));
  }
  return (albedo * light).cwiseMin(1.0);
}

}  // namespace pano4d::synth
