#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "src/core/rigid.h"
#include "src/datasets/synth_texture.h"

namespace pano4d::synth {

// A synthetic dynamic scene for ground truth: a closed room with textured
// walls, static furniture, rigidly moving objects and one non-rigid object
// (a bending tube), rendered by ray tracing.
//
// World frame: z up, metres; the floor is z = 0. Every object is a set of
// parts; a part has a shape fixed in its own frame and a pose that changes
// with normalised time s in [0, 1] (s = t / (T - 1) for frame t of T). The
// texture is a function of the part-frame point, so a surface point keeps
// its identity over time: that is what makes covisibility exact.

enum class ShapeKind { kRoom, kBox, kSphere };
enum class MotionKind { kStatic, kSlide, kBounce, kBend };

struct Part {
  ShapeKind shape = ShapeKind::kBox;
  Eigen::Vector3d half_size =
      Eigen::Vector3d::Ones();  // box/room extents; sphere radius in x
  int instance = 0;  // 1..255, the instance-mask value; 0 is "no surface"
  bool dynamic = false;
  int material = 0;  // the room uses material + face (0..5)
  Eigen::Vector3d texture_offset = Eigen::Vector3d::Zero();
  MotionKind motion = MotionKind::kStatic;
  Rigid3d rest;  // world_from_part at rest
  // Motion parameters: slide/bounce from `from` to `to`; bounce height in
  // `amplitude` with `frequency` bounces; bend angle amplitude (rad),
  // frequency and phase, and the part's place u in [0, 1] along a tube of
  // `length` metres.
  Eigen::Vector3d from = Eigen::Vector3d::Zero();
  Eigen::Vector3d to = Eigen::Vector3d::Zero();
  double amplitude = 0.0;
  double frequency = 1.0;
  double phase = 0.0;
  double u = 0.0;
  double length = 0.0;
};

// Where the cameras stand (synth_cameras.h) and how the scene's looks
// scale. The default is the built-in scene's; `pano4d synth --varied` draws
// one per seed (VariedLayout), so that settings tuned on the default scene
// are judged on scenes they were not tuned on.
struct Layout {
  // The training arc: half its sweep in azimuth around the target, centred
  // on the -y side (-90 degrees), its height and radius in plan.
  double training_half_sweep_degrees = 28.0;
  double training_height = 1.45;
  double training_radius = 2.9;
  // Validation cameras 1 and 2: azimuth from the arc's middle, height,
  // radius in plan.
  double validation_azimuth_degrees[2] = {75.0, -75.0};
  double validation_height[2] = {1.15, 1.85};
  double validation_radius[2] = {2.7, 2.7};
  // Scales the moving objects (BuildScene's dynamic_scale times this).
  double dynamic_scale = 1.0;
  // Multiplies every material's noise frequency (finer or coarser detail).
  double texture_frequency_scale = 1.0;
  // A static object on the line from this validation camera (1 or 2) to
  // the target, `near_object_distance` metres from the camera; 0: none.
  int near_object_camera = 0;
  double near_object_distance = 0.0;
  bool near_object_is_sphere = false;
  double near_object_size = 0.0;  // sphere radius, or the box's half width

  bool IsDefault() const;
  nlohmann::json ToJson() const;
};

// A layout drawn from `seed`: validation cameras 40-85 degrees to either
// side (or both on one side) at heights 0.6-2.4 m and radii 2.0-3.0 m, a
// training arc of 30-70 degrees at 1.1-1.9 m, moving objects 0.7-1.5 times
// their size, textures 0.5-2.5 times their frequency, and in most scenes a
// static object close to a validation camera.
Layout VariedLayout(std::uint32_t seed);

struct Scene {
  Layout layout;
  std::vector<Part> parts;
  std::vector<Material> materials;
  std::vector<Eigen::Vector3d>
      light_directions;  // unit, pointing towards the light
  std::vector<double> light_intensities;
  double ambient = 0.3;
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // where the cameras look
  Eigen::Vector3d room_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d room_max = Eigen::Vector3d::Zero();
};

// The built-in scene; `seed` varies placement, sizes and textures. With
// `is_static` every part stays at one pose (no motion at all).
// `dynamic_scale` scales the moving objects (size and, for the tube, length)
// about their footprint on the floor: > 1 makes them cover more of the
// frame, e.g. to test SfM against large moving objects.
// `layout` places the cameras and the near object and scales sizes and
// textures; the default layout gives the built-in scene.
Scene BuildScene(std::uint32_t seed, bool is_static,
                 double dynamic_scale = 1.0, const Layout& layout = Layout());

// Where validation camera `index` (1 or 2) stands: the layout's azimuth
// from the training arc's middle, radius and height, around the target.
Eigen::Vector3d ValidationEye(const Scene& scene, int index);

// Poses of all parts at normalised time s.
struct PartPoses {
  std::vector<Rigid3d> world_from_part;
  std::vector<Rigid3d> part_from_world;
};
PartPoses PosesAt(const Scene& scene, double s);

struct Hit {
  double distance =
      std::numeric_limits<double>::infinity();  // along the unit ray
  int part = -1;
  int face = 0;  // room: 0..5 = -x, +x, -y, +y, -z, +z
  Eigen::Vector3d local =
      Eigen::Vector3d::Zero();  // hit point in the part frame
  Eigen::Vector3d normal =
      Eigen::Vector3d::Zero();  // world, unit, facing the ray
  bool valid() const { return part >= 0; }
};

// Nearest surface along origin + distance * direction (direction unit).
Hit Intersect(const Scene& scene, const PartPoses& poses,
              const Eigen::Vector3d& origin, const Eigen::Vector3d& direction);

// Lambertian colour of a hit, in [0, 1].
Eigen::Vector3d Shade(const Scene& scene, const Hit& hit);

}  // namespace pano4d::synth
