#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "src/gs/motion.h"
#include "src/render/gaussians.h"

namespace pano4d {

// The 4D scene: static Gaussians in world coordinates, and dynamic
// Gaussians in the canonical frame (the world at time `canonical_time`)
// moved by the motion bases. A scene without dynamic content has no
// dynamic Gaussians, no logits and no bases (empty vectors, K = 0).
struct GaussianScene {
  GaussianModel statics;
  GaussianModel dynamics;     // canonical means and quats
  std::vector<float> logits;  // dynamics.size() x num_bases
  MotionBases bases;
  int num_times = 1;
  int canonical_time = 0;

  std::size_t size() const { return statics.size() + dynamics.size(); }
  bool has_motion() const { return !bases.empty(); }
  // Throws pano4d::Error when arrays disagree in size.
  void Check() const;
  // All Gaussians as they are at `time`: static rows first, then the posed
  // dynamic rows. Reuses `out`'s storage.
  void ComposeAt(int time, GaussianModel* out) const;
};

// Row operations shared by densification, pruning and checkpoints.
// Appends rows `rows` of `from` (indices into it) to `to`.
void AppendGaussianRows(const GaussianModel& from,
                        const std::vector<std::uint32_t>& rows,
                        GaussianModel* to);
// Keeps the rows whose keep[i] != 0, in order.
void KeepGaussianRows(const std::vector<std::uint8_t>& keep,
                      GaussianModel* model);
// The same for any row-major array of `width` values per row.
void KeepRows(const std::vector<std::uint8_t>& keep, int width,
              std::vector<float>* values);
void AppendRows(const std::vector<std::uint32_t>& rows, int width,
                std::vector<float>* values);

float InverseSigmoid(float p);

}  // namespace pano4d
