#include "src/gs/adam.h"

#include <algorithm>
#include <cmath>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/core/option_checks.h"

namespace pano4d {
namespace {

// An optimiser of fewer values than this updates on the calling thread:
// starting a parallel region wakes the sleeping worker threads (passive
// waits, src/cli/main.cc), which costs more than updating this many values
// (docs/experiments/2026-12-03-rasterizer-and-trainer-speed.md).
constexpr std::int64_t kMinParallelWork = 1 << 15;

}  // namespace

void AdamOptions::Check() const {
  if (!(beta1 >= 0 && beta1 < 1))
    throw Error("adam", "beta1", std::to_string(beta1), "must be in [0, 1)");
  if (!(beta2 >= 0 && beta2 < 1))
    throw Error("adam", "beta2", std::to_string(beta2), "must be in [0, 1)");
  CheckPositive(epsilon, "adam", "epsilon");
}

Adam::Adam(AdamOptions options) : options_(options) { options_.Check(); }

int Adam::AddGroup(std::string name, std::vector<float>* params, int width,
                   double lr) {
  PANO4D_CHECK(params != nullptr && width > 0 && params->size() % width == 0,
               "Adam group " + name + ": " +
                   std::to_string(params ? params->size() : 0) +
                   " parameters are not rows of " + std::to_string(width));
  const std::int64_t rows = static_cast<std::int64_t>(params->size()) / width;
  PANO4D_CHECK(groups_.empty() || rows == rows_,
               "Adam group " + name + " has " + std::to_string(rows) +
                   " rows, the other groups " + std::to_string(rows_));
  rows_ = rows;
  groups_.push_back({std::move(name), params, width, lr,
                     std::vector<float>(params->size(), 0.0f),
                     std::vector<float>(params->size(), 0.0f)});
  return static_cast<int>(groups_.size()) - 1;
}

std::string Adam::RestoreRows() {
  if (groups_.empty()) return "";
  rows_ =
      static_cast<std::int64_t>(groups_[0].params->size()) / groups_[0].width;
  for (const Group& g : groups_) {
    if (static_cast<std::int64_t>(g.params->size()) != rows_ * g.width)
      return "group " + g.name + ": " + std::to_string(g.params->size()) +
             " parameters are not " + std::to_string(rows_) + " rows";
    if (g.m.size() != g.params->size() || g.v.size() != g.params->size())
      return "group " + g.name + ": " + std::to_string(g.m.size()) + " and " +
             std::to_string(g.v.size()) + " moments for " +
             std::to_string(g.params->size()) + " parameters";
  }
  return "";
}

void Adam::SetLearningRate(int group, double lr) { groups_.at(group).lr = lr; }

void Adam::CheckSizes() const {
  for (const Group& g : groups_) {
    PANO4D_CHECK(
        static_cast<std::int64_t>(g.params->size()) == rows_ * g.width &&
            g.m.size() == g.params->size(),
        "Adam group " + g.name + ": " + std::to_string(g.params->size()) +
            " parameters changed size without AppendRows/KeepRows (" +
            std::to_string(rows_) + " rows expected)");
  }
}

AdamStepStats Adam::Step(
    const std::vector<const std::vector<float>*>& gradients) {
  PANO4D_CHECK(gradients.size() == groups_.size(),
               "Adam::Step got " + std::to_string(gradients.size()) +
                   " gradients for " + std::to_string(groups_.size()) +
                   " groups");
  CheckSizes();
  ++step_;
  const double b1 = options_.beta1, b2 = options_.beta2;
  const double correction1 = 1 - std::pow(b1, static_cast<double>(step_));
  const double correction2 = 1 - std::pow(b2, static_cast<double>(step_));
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    const std::vector<float>* grad = gradients[gi];
    PANO4D_CHECK(grad == nullptr || grad->empty() ||
                     grad->size() == groups_[gi].params->size(),
                 "Adam group " + groups_[gi].name + ": a gradient of " +
                     std::to_string(grad ? grad->size() : 0) + " values for " +
                     std::to_string(groups_[gi].params->size()) +
                     " parameters");
  }
  const double root_correction2 = std::sqrt(correction2);
  std::int64_t skipped = 0;
  // One parallel region for every group (the groups are independent, so
  // no barrier between them): each region start wakes the worker threads,
  // which on a busy machine or with passive waits costs more than a
  // small group's update; an optimiser of few values (the motion bases',
  // the appearance transforms') runs on the calling thread.
  std::int64_t work = 0;
  for (const Group& g : groups_) work += rows_ * g.width;
#pragma omp parallel reduction(+ : skipped) if (work >= kMinParallelWork)
  for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
    Group& g = groups_[gi];
    const std::vector<float>* grad = gradients[gi];
    if (grad == nullptr || grad->empty()) continue;
    const double step_size = g.lr / correction1;
    std::vector<float>& p = *g.params;
#pragma omp for schedule(static) nowait
    for (std::int64_t row = 0; row < rows_; ++row) {
      const std::size_t begin = static_cast<std::size_t>(row) * g.width;
      bool finite = true;
      for (int k = 0; k < g.width; ++k)
        finite = finite && std::isfinite((*grad)[begin + k]);
      if (!finite) {
        ++skipped;
        continue;
      }
      for (int k = 0; k < g.width; ++k) {
        const std::size_t i = begin + k;
        const double gradient = (*grad)[i];
        const double m = b1 * g.m[i] + (1 - b1) * gradient;
        const double v = b2 * g.v[i] + (1 - b2) * gradient * gradient;
        g.m[i] = static_cast<float>(m);
        g.v[i] = static_cast<float>(v);
        p[i] -= static_cast<float>(
            step_size * m /
            (std::sqrt(v) / root_correction2 + options_.epsilon));
      }
    }
  }
  AdamStepStats stats;
  stats.skipped_rows = skipped;
  return stats;
}

void Adam::AppendRows(std::int64_t count) {
  rows_ += count;
  for (Group& g : groups_) {
    g.m.resize(static_cast<std::size_t>(rows_) * g.width, 0.0f);
    g.v.resize(static_cast<std::size_t>(rows_) * g.width, 0.0f);
  }
  CheckSizes();
}

void Adam::KeepRows(const std::vector<std::uint8_t>& keep) {
  PANO4D_CHECK(static_cast<std::int64_t>(keep.size()) == rows_,
               "Adam::KeepRows got " + std::to_string(keep.size()) +
                   " flags for " + std::to_string(rows_) + " rows");
  const std::int64_t kept =
      std::count_if(keep.begin(), keep.end(), [](std::uint8_t k) { return k; });
  for (Group& g : groups_) {
    std::size_t out = 0;
    for (std::int64_t row = 0; row < rows_; ++row) {
      if (!keep[row]) continue;
      for (int k = 0; k < g.width; ++k, ++out) {
        g.m[out] = g.m[row * g.width + k];
        g.v[out] = g.v[row * g.width + k];
      }
    }
    g.m.resize(out);
    g.v.resize(out);
  }
  rows_ = kept;
  CheckSizes();
}

double ExponentialLearningRate(double lr_init, double lr_final,
                               std::int64_t step, std::int64_t max_steps) {
  if (max_steps <= 0 || step >= max_steps) return lr_final;
  if (step <= 0) return lr_init;
  const double t = static_cast<double>(step) / static_cast<double>(max_steps);
  return std::exp(std::log(lr_init) * (1 - t) + std::log(lr_final) * t);
}

}  // namespace pano4d
