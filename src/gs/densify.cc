// Trainer: densification (clone and split by screen-space gradient),
// pruning, opacity reset, and the static Gaussians that the expansion adds
// and carves (src/gs/trainer.h).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "src/core/error.h"
#include "src/gs/trainer.h"

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

}  // namespace

void Trainer::Densify(bool prune_large) {
  const std::size_t ns = scene_.statics.size();
  const double threshold = options_.densify_gradient;
  const double dense = options_.percent_dense * extent_;
  std::normal_distribution<float> normal;

  struct Candidate {
    float gradient;
    std::uint32_t row;  // in the composed order
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < grad_accum_.size(); ++i) {
    if (grad_count_[i] == 0) continue;
    const float g = grad_accum_[i] / grad_count_[i];
    if (g >= threshold)
      candidates.push_back({g, static_cast<std::uint32_t>(i)});
  }
  // At the cap, the largest gradients go first.
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) {
                     return a.gradient > b.gradient;
                   });
  const std::int64_t budget = std::max<std::int64_t>(
      0, options_.max_gaussians - static_cast<std::int64_t>(scene_.size()));
  if (static_cast<std::int64_t>(candidates.size()) > budget)
    candidates.resize(budget);
  std::sort(
      candidates.begin(), candidates.end(),
      [](const Candidate& a, const Candidate& b) { return a.row < b.row; });

  std::int64_t added = 0, removed = 0;
  const auto process = [&](GaussianModel* model, std::vector<float>* logits,
                           int k, Adam* adam, std::size_t offset,
                           std::size_t count) {
    if (count == 0) return;
    std::vector<std::uint32_t> clone, split;
    for (const Candidate& c : candidates) {
      if (c.row < offset || c.row >= offset + count) continue;
      const std::uint32_t r = c.row - static_cast<std::uint32_t>(offset);
      const float* s = &model->log_scales[r * 3];
      const float largest = std::exp(std::max({s[0], s[1], s[2]}));
      (largest > dense ? split : clone).push_back(r);
    }
    // Clones: exact copies (their gradients will differ from the next step).
    AppendGaussianRows(*model, clone, model);
    if (logits) AppendRows(clone, k, logits);
    // Splits: kSplitSamples samples drawn from the Gaussian, scales shrunk.
    std::vector<std::uint32_t> split_rows;
    for (std::uint32_t r : split)
      for (int j = 0; j < kSplitSamples; ++j) split_rows.push_back(r);
    const std::size_t first_split = model->size();
    AppendGaussianRows(*model, split_rows, model);
    if (logits) AppendRows(split_rows, k, logits);
    for (std::size_t j = 0; j < split_rows.size(); ++j) {
      const std::size_t row = first_split + j;
      float* mean = &model->means[row * 3];
      float* ls = &model->log_scales[row * 3];
      const float* q = &model->quats[row * 4];
      Eigen::Quaternionf rot(q[0], q[1], q[2], q[3]);
      if (rot.norm() < kMinQuaternionNorm) rot = Eigen::Quaternionf::Identity();
      rot.normalize();
      Eigen::Vector3f local;
      for (int c = 0; c < 3; ++c) local[c] = std::exp(ls[c]) * normal(rng_);
      const Eigen::Vector3f offset_world = rot * local;
      for (int c = 0; c < 3; ++c) {
        mean[c] += offset_world[c];
        ls[c] -= std::log(kSplitScaleDivisor);
      }
    }
    adam->AppendRows(
        static_cast<std::int64_t>(clone.size() + split_rows.size()));
    added += static_cast<std::int64_t>(clone.size() + split_rows.size());

    // Remove split originals and pruned Gaussians.
    std::vector<std::uint8_t> keep(model->size(), 1);
    for (std::uint32_t r : split) keep[r] = 0;
    for (std::size_t i = 0; i < model->size(); ++i) {
      if (Sigmoid(model->opacities[i]) < options_.prune_opacity) keep[i] = 0;
      if (prune_large) {
        const float* s = &model->log_scales[i * 3];
        const float largest = std::exp(std::max({s[0], s[1], s[2]}));
        const bool too_wide = largest > kMaxWorldScaleFraction * extent_;
        const bool too_big_on_screen =
            i < count && max_radius_[offset + i] > options_.max_screen_radius;
        if (too_wide || too_big_on_screen) keep[i] = 0;
      }
    }
    const std::size_t before = model->size();
    KeepGaussianRows(keep, model);
    if (logits) KeepRows(keep, k, logits);
    adam->KeepRows(keep);
    removed += static_cast<std::int64_t>(before - model->size()) -
               static_cast<std::int64_t>(split.size());
  };
  const std::size_t nd = scene_.dynamics.size();
  process(&scene_.statics, nullptr, 0, &static_adam_, 0, ns);
  process(&scene_.dynamics, &scene_.logits, scene_.bases.num_bases,
          &dynamic_adam_, ns, nd);
  densified_total_ += added;
  pruned_total_ += removed;
  const std::size_t n = scene_.size();
  grad_accum_.assign(n, 0.0f);
  max_radius_.assign(n, 0.0f);
  grad_count_.assign(n, 0);
}

std::int64_t Trainer::AddStaticGaussians(const GaussianModel& extra) {
  if (extra.sh_degree != scene_.statics.sh_degree) {
    throw Error("trainer", "sh_degree", std::to_string(extra.sh_degree),
                "added Gaussians must have the scene's SH degree " +
                    std::to_string(scene_.statics.sh_degree));
  }
  const std::int64_t room = std::max<std::int64_t>(
      0, options_.max_gaussians - static_cast<std::int64_t>(scene_.size()));
  const std::int64_t count =
      std::min<std::int64_t>(room, static_cast<std::int64_t>(extra.size()));
  if (count == 0) return 0;
  std::vector<std::uint32_t> rows(static_cast<std::size_t>(count));
  std::iota(rows.begin(), rows.end(), 0u);
  const std::size_t ns = scene_.statics.size();
  AppendGaussianRows(extra, rows, &scene_.statics);
  static_adam_.AppendRows(count);
  // Densification statistics are in composed order: statics, then dynamics.
  const auto insert = [&](auto* v) {
    v->insert(v->begin() + static_cast<std::ptrdiff_t>(ns),
              static_cast<std::size_t>(count), 0);
  };
  insert(&grad_accum_);
  insert(&max_radius_);
  insert(&grad_count_);
  return count;
}

std::int64_t Trainer::RemoveStaticGaussians(
    const std::vector<std::uint8_t>& keep) {
  const std::size_t ns = scene_.statics.size();
  if (keep.size() != ns) {
    throw Error(
        "trainer", "keep", std::to_string(keep.size()),
        "expected one flag per static Gaussian (" + std::to_string(ns) + ")");
  }
  const auto removed = static_cast<std::int64_t>(
      std::count(keep.begin(), keep.end(), std::uint8_t{0}));
  if (removed == 0) return 0;
  KeepGaussianRows(keep, &scene_.statics);
  static_adam_.KeepRows(keep);
  // Densification statistics are in composed order: statics, then dynamics.
  const auto drop = [&](auto* v) {
    std::size_t out = 0;
    for (std::size_t i = 0; i < v->size(); ++i)
      if (i >= ns || keep[i]) (*v)[out++] = (*v)[i];
    v->resize(out);
  };
  drop(&grad_accum_);
  drop(&max_radius_);
  drop(&grad_count_);
  pruned_total_ += removed;
  return removed;
}

void Trainer::ResetOpacities() {
  const float cap = InverseSigmoid(kResetOpacity);
  for (float& o : scene_.statics.opacities) o = std::min(o, cap);
  for (float& o : scene_.dynamics.opacities) o = std::min(o, cap);
  // 3DGS replaces the opacity tensor: its optimiser state starts afresh.
  for (Adam* adam : {&static_adam_, &dynamic_adam_}) {
    for (int g = 0; g < adam->groups(); ++g) {
      if (adam->name(g) != "opacities") continue;
      std::fill(adam->first_moment(g).begin(), adam->first_moment(g).end(),
                0.0f);
      std::fill(adam->second_moment(g).begin(), adam->second_moment(g).end(),
                0.0f);
    }
  }
  reset_done_ = true;
}

}  // namespace pano4d
