// DefaultStrategy: 3DGS's adaptive density control (strategy.h).
#include "src/gs/strategy.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include <Eigen/Geometry>

#include "src/core/check.h"

namespace pano4d {
namespace {

// Opacity that 3DGS's reset caps every Gaussian at.
constexpr float kResetOpacity = 0.01f;
// 3DGS's split: two samples, scales divided by 0.8 x 2.
constexpr int kSplitSamples = 2;
constexpr float kSplitScaleDivisor = 1.6f;
// Pruning by world size: larger than this fraction of the scene extent.
constexpr double kMaxWorldScaleFraction = 0.1;

float Sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

float LargestScale(const GaussianModel& model, std::size_t row) {
  const float* s = &model.log_scales[row * 3];
  return std::exp(std::max({s[0], s[1], s[2]}));
}

struct Candidate {
  float gradient;
  std::uint32_t row;  // in the composed order
};

// The rows whose mean screen-space gradient reaches `threshold`, at most
// `budget` of them (the largest gradients first), in row order.
std::vector<Candidate> DensifyCandidates(const DensifyStatistics& stats,
                                         double threshold,
                                         std::int64_t budget) {
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < stats.gradient.size(); ++i) {
    if (stats.count[i] == 0) continue;
    const float g = stats.gradient[i] / stats.count[i];
    if (g >= threshold)
      candidates.push_back({g, static_cast<std::uint32_t>(i)});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) {
                     return a.gradient > b.gradient;
                   });
  if (static_cast<std::int64_t>(candidates.size()) > budget)
    candidates.resize(budget);
  std::sort(
      candidates.begin(), candidates.end(),
      [](const Candidate& a, const Candidate& b) { return a.row < b.row; });
  return candidates;
}

// One model of the scene with its rows of the composed order [offset,
// offset + count), its basis weights (dynamics: k per row) and optimiser.
struct ModelRows {
  GaussianModel* model;
  std::vector<float>* logits;  // null for the statics
  int k;
  Adam* adam;
  std::size_t offset, count;
};

// The candidates of `m` no larger than `dense` cloned as they are, the
// larger ones split into kSplitSamples samples drawn from them with their
// scales shrunk; returns the rows split (whose originals go) and adds the
// rows appended to `added`.
std::vector<std::uint32_t> CloneAndSplit(
    const std::vector<Candidate>& candidates, double dense, const ModelRows& m,
    std::normal_distribution<float>* normal, std::mt19937_64* rng,
    std::int64_t* added) {
  GaussianModel* model = m.model;
  std::vector<std::uint32_t> clone, split;
  for (const Candidate& c : candidates) {
    if (c.row < m.offset || c.row >= m.offset + m.count) continue;
    const std::uint32_t r = c.row - static_cast<std::uint32_t>(m.offset);
    (LargestScale(*model, r) > dense ? split : clone).push_back(r);
  }
  // Clones: exact copies (their gradients will differ from the next step).
  AppendGaussianRows(*model, clone, model);
  if (m.logits) AppendRows(clone, m.k, m.logits);
  std::vector<std::uint32_t> split_rows;
  for (std::uint32_t r : split)
    for (int j = 0; j < kSplitSamples; ++j) split_rows.push_back(r);
  const std::size_t first_split = model->size();
  AppendGaussianRows(*model, split_rows, model);
  if (m.logits) AppendRows(split_rows, m.k, m.logits);
  for (std::size_t j = 0; j < split_rows.size(); ++j) {
    const std::size_t row = first_split + j;
    float* mean = &model->means[row * 3];
    float* ls = &model->log_scales[row * 3];
    const float* q = &model->quats[row * 4];
    Eigen::Quaternionf rot(q[0], q[1], q[2], q[3]);
    if (rot.norm() < kMinQuaternionNorm) rot = Eigen::Quaternionf::Identity();
    rot.normalize();
    Eigen::Vector3f local;
    for (int c = 0; c < 3; ++c) local[c] = std::exp(ls[c]) * (*normal)(*rng);
    const Eigen::Vector3f offset_world = rot * local;
    for (int c = 0; c < 3; ++c) {
      mean[c] += offset_world[c];
      ls[c] -= std::log(kSplitScaleDivisor);
    }
  }
  m.adam->AppendRows(
      static_cast<std::int64_t>(clone.size() + split_rows.size()));
  *added += static_cast<std::int64_t>(clone.size() + split_rows.size());
  return split;
}

// Removes the split originals, the faint Gaussians and, after the first
// opacity reset, those too wide in the world or on screen; returns the count
// removed besides the split originals.
std::int64_t Prune(const ModelRows& m, const std::vector<std::uint32_t>& split,
                   const DensifyStatistics& stats,
                   const StrategyOptions& options, double extent) {
  GaussianModel* model = m.model;
  // Large Gaussians are pruned only after the first opacity reset (3DGS).
  const bool prune_large = stats.reset_done;
  std::vector<std::uint8_t> keep(model->size(), 1);
  for (std::uint32_t r : split) keep[r] = 0;
  for (std::size_t i = 0; i < model->size(); ++i) {
    if (Sigmoid(model->opacities[i]) < options.prune_opacity) keep[i] = 0;
    if (prune_large) {
      const bool too_wide =
          LargestScale(*model, i) > kMaxWorldScaleFraction * extent;
      const bool too_big_on_screen =
          i < m.count &&
          stats.max_radius[m.offset + i] > options.max_screen_radius;
      if (too_wide || too_big_on_screen) keep[i] = 0;
    }
  }
  const std::size_t before = model->size();
  KeepGaussianRows(keep, model);
  if (m.logits) KeepRows(keep, m.k, m.logits);
  m.adam->KeepRows(keep);
  return static_cast<std::int64_t>(before - model->size()) -
         static_cast<std::int64_t>(split.size());
}

}  // namespace

void DensifyStatistics::Assign(std::size_t n) {
  gradient.assign(n, 0.0f);
  max_radius.assign(n, 0.0f);
  count.assign(n, 0);
}

DefaultStrategy::DefaultStrategy(const StrategyOptions& options, double extent,
                                 std::size_t gaussians)
    : options_(options), extent_(extent) {
  stats_.Assign(gaussians);
}

void DefaultStrategy::StepPreForward(std::int64_t iteration,
                                     OptimisedScene scene) {
  if (iteration > 0 && iteration < options_.densify_until &&
      iteration % options_.opacity_reset_every == 0) {
    ResetOpacities(scene);
  }
}

void DefaultStrategy::StepPostBackward(const RasterState& state,
                                       const GaussianGradients& grads) {
  const std::vector<int>& radius = state.projected.radius;
  PANO4D_CHECK(radius.size() == stats_.gradient.size() &&
                   grads.means2d.size() == 2 * radius.size(),
               "densification statistics of " +
                   std::to_string(stats_.gradient.size()) +
                   " Gaussians, the forward state holds " +
                   std::to_string(radius.size()) + " and the gradients " +
                   std::to_string(grads.means2d.size() / 2));
  const int w = state.width, h = state.height;
  for (std::size_t i = 0; i < radius.size(); ++i) {
    if (radius[i] <= 0) continue;
    const float gx = grads.means2d[i * 2] * 0.5f * w;
    const float gy = grads.means2d[i * 2 + 1] * 0.5f * h;
    stats_.gradient[i] += std::sqrt(gx * gx + gy * gy);
    stats_.count[i] += 1;
    stats_.max_radius[i] =
        std::max(stats_.max_radius[i], static_cast<float>(radius[i]));
  }
}

void DefaultStrategy::StepPostOptimise(std::int64_t iteration,
                                       OptimisedScene scene,
                                       std::mt19937_64* rng) {
  if (iteration >= options_.densify_from &&
      iteration < options_.densify_until &&
      iteration % options_.densify_every == 0) {
    Densify(scene, rng);
  }
}

void DefaultStrategy::Densify(OptimisedScene optimised, std::mt19937_64* rng) {
  GaussianScene& scene = *optimised.scene;
  const std::size_t ns = scene.statics.size(), nd = scene.dynamics.size();
  const std::vector<Candidate> candidates = DensifyCandidates(
      stats_, options_.densify_gradient,
      std::max<std::int64_t>(
          0, options_.max_gaussians - static_cast<std::int64_t>(scene.size())));
  const double dense = options_.percent_dense * extent_;
  // One distribution for both models: it keeps the second of each pair of
  // samples it draws.
  std::normal_distribution<float> normal;
  std::int64_t added = 0, removed = 0;
  for (const ModelRows& m :
       {ModelRows{&scene.statics, nullptr, 0, optimised.statics, 0, ns},
        ModelRows{&scene.dynamics, &scene.logits, scene.bases.num_bases,
                  optimised.dynamics, ns, nd}}) {
    if (m.count == 0) continue;
    const std::vector<std::uint32_t> split =
        CloneAndSplit(candidates, dense, m, &normal, rng, &added);
    removed += Prune(m, split, stats_, options_, extent_);
  }
  densified_total_ += added;
  pruned_total_ += removed;
  stats_.Assign(scene.size());
}

std::int64_t DefaultStrategy::AddStatic(OptimisedScene optimised,
                                        const GaussianModel& extra) {
  GaussianScene& scene = *optimised.scene;
  PANO4D_CHECK(extra.sh_degree == scene.statics.sh_degree,
               "added Gaussians of SH degree " +
                   std::to_string(extra.sh_degree) + ", the scene's is " +
                   std::to_string(scene.statics.sh_degree));
  const std::int64_t room = std::max<std::int64_t>(
      0, options_.max_gaussians - static_cast<std::int64_t>(scene.size()));
  const std::int64_t count =
      std::min<std::int64_t>(room, static_cast<std::int64_t>(extra.size()));
  if (count == 0) return 0;
  std::vector<std::uint32_t> rows(static_cast<std::size_t>(count));
  std::iota(rows.begin(), rows.end(), 0u);
  const std::size_t ns = scene.statics.size();
  AppendGaussianRows(extra, rows, &scene.statics);
  optimised.statics->AppendRows(count);
  // The statistics are in composed order: statics, then dynamics.
  const auto insert = [&](auto* v) {
    v->insert(v->begin() + static_cast<std::ptrdiff_t>(ns),
              static_cast<std::size_t>(count), 0);
  };
  insert(&stats_.gradient);
  insert(&stats_.max_radius);
  insert(&stats_.count);
  return count;
}

std::int64_t DefaultStrategy::RemoveStatic(
    OptimisedScene optimised, const std::vector<std::uint8_t>& keep) {
  GaussianScene& scene = *optimised.scene;
  const std::size_t ns = scene.statics.size();
  PANO4D_CHECK(keep.size() == ns, std::to_string(keep.size()) +
                                      " keep flags for " + std::to_string(ns) +
                                      " static Gaussians");
  const auto removed = static_cast<std::int64_t>(
      std::count(keep.begin(), keep.end(), std::uint8_t{0}));
  if (removed == 0) return 0;
  KeepGaussianRows(keep, &scene.statics);
  optimised.statics->KeepRows(keep);
  // The statistics are in composed order: statics, then dynamics.
  const auto drop = [&](auto* v) {
    std::size_t out = 0;
    for (std::size_t i = 0; i < v->size(); ++i)
      if (i >= ns || keep[i]) (*v)[out++] = (*v)[i];
    v->resize(out);
  };
  drop(&stats_.gradient);
  drop(&stats_.max_radius);
  drop(&stats_.count);
  pruned_total_ += removed;
  return removed;
}

void DefaultStrategy::ResetOpacities(OptimisedScene optimised) {
  const float cap = InverseSigmoid(kResetOpacity);
  for (float& o : optimised.scene->statics.opacities) o = std::min(o, cap);
  for (float& o : optimised.scene->dynamics.opacities) o = std::min(o, cap);
  // 3DGS replaces the opacity tensor: its optimiser state starts afresh.
  for (Adam* adam : {optimised.statics, optimised.dynamics}) {
    for (int g = 0; g < adam->groups(); ++g) {
      if (adam->name(g) != "opacities") continue;
      std::fill(adam->first_moment(g).begin(), adam->first_moment(g).end(),
                0.0f);
      std::fill(adam->second_moment(g).begin(), adam->second_moment(g).end(),
                0.0f);
    }
  }
  stats_.reset_done = true;
}

}  // namespace pano4d
