#include "src/gs/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/log.h"
#include "src/core/median.h"
#include "src/core/npy.h"
#include "src/core/psnr.h"
#include "src/gs/loss.h"
#include "src/gs/prior_loss.h"
#include "src/gs/surface_loss.h"

namespace pano4d {
namespace {

// Learning rates of positions decay to this fraction over the run (3DGS:
// 1.6e-4 -> 1.6e-6).
constexpr double kFinalLearningRateFraction = 0.01;
// 3DGS's first densification, once the initial Gaussians have settled.
constexpr int kDensifyFrom = 500;

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The expansion's loss on `extra` (ExtraView, trainer.h) for the render
// `rgb`, with its gradient in *d_rgb (zero where unsupervised); nothing when
// the mask is empty or the sizes disagree.
std::optional<double> RefinementLoss(const std::vector<float>& rgb,
                                     const ExtraView& extra,
                                     std::vector<float>* d_rgb) {
  const std::size_t pixels = extra.mask.size();
  const auto count = static_cast<std::size_t>(
      std::count_if(extra.mask.begin(), extra.mask.end(),
                    [](std::uint8_t m) { return m != 0; }));
  d_rgb->assign(rgb.size(), 0.0f);
  if (count == 0 || rgb.size() != pixels * 3 ||
      extra.target.size() != pixels * 3)
    return std::nullopt;
  const double norm = 1.0 / (3.0 * count);
  double sum = 0;
  for (std::size_t p = 0; p < pixels; ++p) {
    const double w = extra.mask[p] ? 1.0 : extra.outside_weight;
    if (w == 0.0) continue;
    for (int c = 0; c < 3; ++c) {
      const double e = double(rgb[p * 3 + c]) - extra.target[p * 3 + c];
      sum += w * e * e;
      (*d_rgb)[p * 3 + c] =
          static_cast<float>(2.0 * w * extra.weight * norm * e);
    }
  }
  return extra.weight * sum * norm;
}

}  // namespace

Trainer::Trainer(GaussianScene scene, std::vector<TrainingView> views,
                 TrainerOptions options, std::uint64_t seed)
    : options_(std::move(options)),
      scene_(std::move(scene)),
      views_(std::move(views)),
      rng_(seed) {
  options_.Check();
  scene_.Check();
  if (options_.strategy.densify_until < 0)
    options_.strategy.densify_until = options_.iterations / 2;
  // A short schedule still densifies over half its window.
  if (options_.strategy.densify_from < 0)
    options_.strategy.densify_from = std::min(
        kDensifyFrom, std::max(1, options_.strategy.densify_until / 2));
  fingerprint_ = options_.ToJson();
  if (views_.empty()) {
    throw Error("fit", "views", "0", "no training views");
  }
  scene_fingerprint_ = ViewsFingerprint(views_);
  for (const TrainingView& v : views_) {
    if (v.time < 0 || v.time >= scene_.num_times) {
      throw Error(
          "fit", "view " + v.name + " time", std::to_string(v.time),
          "outside the scene's " + std::to_string(scene_.num_times) + " times");
    }
  }
  // The scene extent scales position learning rates and the densification
  // thresholds. 3DGS takes 1.1 x the cameras' radius; a video camera may
  // barely move, so the median depth of the views bounds it from below (the
  // size of what the cameras look at).
  Eigen::Vector3f mean_centre = Eigen::Vector3f::Zero();
  for (const TrainingView& v : views_) mean_centre += v.camera.Center();
  mean_centre /= static_cast<float>(views_.size());
  double radius = 0;
  for (const TrainingView& v : views_)
    radius = std::max(radius, double((v.camera.Center() - mean_centre).norm()));
  median_depth_.assign(views_.size(), 0.0f);
  std::vector<float> medians;
  for (std::size_t i = 0; i < views_.size(); ++i) {
    std::vector<float> valid;
    for (float d : views_[i].depth)
      if (d > 0) valid.push_back(d);
    if (valid.empty()) continue;
    median_depth_[i] = UpperMedian(std::move(valid));
    medians.push_back(median_depth_[i]);
  }
  const double depth_scale = UpperMedian(std::move(medians));
  extent_ = std::max(1.1 * radius, depth_scale);
  if (!(extent_ > 0)) extent_ = 1.0;
  if (options_.max_static_scale_pixels > 0) {
    std::vector<double> focals;
    for (const TrainingView& v : views_)
      focals.push_back(0.5 * (v.camera.fx + v.camera.fy));
    const double depth = depth_scale > 0 ? depth_scale : extent_;
    max_static_log_scale_ =
        static_cast<float>(std::log(options_.max_static_scale_pixels * depth /
                                    UpperMedian(std::move(focals))));
  }
  appearance_.clear();
  for (std::size_t i = 0; i < views_.size(); ++i) {
    const std::vector<float> identity = IdentityAppearance();
    appearance_.insert(appearance_.end(), identity.begin(), identity.end());
  }
  RegisterGroups();
  UpdateLearningRates();
  strategy_ = DefaultStrategy(options_.strategy, extent_, scene_.size());
}

void Trainer::RegisterGroups() {
  // The Gaussians' five groups; returns the means' index (its learning
  // rate follows the schedule).
  const auto add_model = [&](Adam* adam, GaussianModel* m) {
    const int means = adam->AddGroup("means", &m->means, 3, 0);
    adam->AddGroup("log_scales", &m->log_scales, 3, options_.lr_log_scale);
    adam->AddGroup("quats", &m->quats, 4, options_.lr_quat);
    adam->AddGroup("opacities", &m->opacities, 1, options_.lr_opacity);
    adam->AddGroup("sh", &m->sh, m->sh_coefficients() * 3, options_.lr_sh);
    return means;
  };
  static_mean_group_ = add_model(&static_adam_, &scene_.statics);
  if (options_.appearance) {
    appearance_adam_.AddGroup("affine", &appearance_, kAppearanceWidth,
                              options_.lr_appearance);
  }
  if (!scene_.has_motion()) return;
  dynamic_mean_group_ = add_model(&dynamic_adam_, &scene_.dynamics);
  dynamic_adam_.AddGroup("logits", &scene_.logits, scene_.bases.num_bases,
                         options_.lr_logit);
  MotionBases& b = scene_.bases;
  basis_adam_.AddGroup("rotations", &b.rotations, b.num_times * 4,
                       options_.lr_basis_rotation);
  basis_translation_group_ =
      basis_adam_.AddGroup("translations", &b.translations, b.num_times * 3, 0);
}

void Trainer::UpdateLearningRates() {
  const auto decayed = [&](double lr) {
    return ExponentialLearningRate(lr * extent_,
                                   lr * extent_ * kFinalLearningRateFraction,
                                   iteration_, options_.iterations);
  };
  static_adam_.SetLearningRate(static_mean_group_, decayed(options_.lr_mean));
  if (options_.appearance) {
    appearance_adam_.SetLearningRate(
        0, ExponentialLearningRate(
               options_.lr_appearance,
               options_.lr_appearance * kFinalLearningRateFraction, iteration_,
               options_.iterations));
  }
  if (scene_.has_motion()) {
    dynamic_adam_.SetLearningRate(dynamic_mean_group_,
                                  decayed(options_.lr_mean));
    basis_adam_.SetLearningRate(basis_translation_group_,
                                decayed(options_.lr_basis_translation));
  }
}

RasterSettings Trainer::Settings() const {
  RasterSettings settings;
  settings.background = options_.background;
  return settings;
}

int Trainer::NextView() {
  if (order_pos_ >= order_.size()) {
    order_.resize(views_.size());
    std::iota(order_.begin(), order_.end(), 0);
    std::shuffle(order_.begin(), order_.end(), rng_);
    order_pos_ = 0;
  }
  return order_[order_pos_++];
}

void Trainer::Render(const RasterCamera& camera, int time, RenderOutput* out,
                     int appearance_view) {
  const RasterSettings settings = Settings();
  scene_.ComposeAt(time, &composed_);
  rasterizer_.Render(composed_, camera, settings, out);
  if (appearance_view < 0) return;
  if (appearance_view >= static_cast<int>(views_.size())) {
    throw Error(
        "render", "appearance view", std::to_string(appearance_view),
        "there are " + std::to_string(views_.size()) + " training views");
  }
  std::vector<float> corrected;
  ApplyAppearance(appearance(appearance_view), out->rgb, &corrected);
  out->rgb.swap(corrected);
}

void Trainer::Backprop(const RasterCamera& camera, int time,
                       const RasterState& state, const RenderOutput& out,
                       const RenderGradients& d_out,
                       const GaussianGradients* direct) {
  rasterizer_.Backward(composed_, camera, Settings(), state, out, d_out,
                       &grads_);
  if (gradient_hook) gradient_hook(&grads_);
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(composed_.size());
  // The losses' own gradients on the composed Gaussians (null: none).
  const auto given = [&](std::vector<float> GaussianGradients::*field) {
    return direct != nullptr && !(direct->*field).empty()
               ? (direct->*field).data()
               : nullptr;
  };
  const float* direct_means = given(&GaussianGradients::means);
  const float* direct_log_scales = given(&GaussianGradients::log_scales);
  const float* direct_quats = given(&GaussianGradients::quats);

  // The losses' own gradients join the rasterizer's; a Gaussian with any
  // non-finite gradient is left out of this step (its gradient zeroed, so
  // that it cannot reach the shared motion bases), and counted. The others'
  // gradients join the static or dynamic groups'.
  const std::ptrdiff_t ns = static_cast<std::ptrdiff_t>(scene_.statics.size());
  const int k3 = composed_.sh_coefficients() * 3;
  std::int64_t bad = 0;
#pragma omp parallel for schedule(static) reduction(+ : bad)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    float* means = &grads_.means[i * 3];
    float* log_scales = &grads_.log_scales[i * 3];
    float* quats = &grads_.quats[i * 4];
    float* sh = &grads_.sh[i * k3];
    float* means2d = &grads_.means2d[i * 2];
    if (direct_means)
      for (int j = 0; j < 3; ++j) means[j] += direct_means[i * 3 + j];
    if (direct_log_scales)
      for (int j = 0; j < 3; ++j) log_scales[j] += direct_log_scales[i * 3 + j];
    if (direct_quats)
      for (int j = 0; j < 4; ++j) quats[j] += direct_quats[i * 4 + j];
    bool finite = std::isfinite(grads_.opacities[i]);
    for (int j = 0; j < 3; ++j)
      finite =
          finite && std::isfinite(means[j]) && std::isfinite(log_scales[j]);
    for (int j = 0; j < 4; ++j) finite = finite && std::isfinite(quats[j]);
    for (int j = 0; j < k3; ++j) finite = finite && std::isfinite(sh[j]);
    for (int j = 0; j < 2; ++j) finite = finite && std::isfinite(means2d[j]);
    if (!finite) {
      ++bad;
      grads_.opacities[i] = 0;
      std::fill_n(means, 3, 0.0f);
      std::fill_n(log_scales, 3, 0.0f);
      std::fill_n(quats, 4, 0.0f);
      std::fill_n(sh, k3, 0.0f);
      std::fill_n(means2d, 2, 0.0f);
    }
    // Dynamic rows' means and quaternions reach their canonical ones
    // through the motion (below).
    GaussianGradients& to = i < ns ? static_grads_ : dynamic_grads_;
    const std::ptrdiff_t r = i < ns ? i : i - ns;
    if (i < ns) {
      for (int j = 0; j < 3; ++j) to.means[r * 3 + j] += means[j];
      for (int j = 0; j < 4; ++j) to.quats[r * 4 + j] += quats[j];
    }
    for (int j = 0; j < 3; ++j) to.log_scales[r * 3 + j] += log_scales[j];
    to.opacities[r] += grads_.opacities[i];
    for (int j = 0; j < k3; ++j) to.sh[r * k3 + j] += sh[j];
  }
  if (bad > 0) {
    skipped_rows_total_ += bad;
    PANO4D_LOG(kWarning) << "fit: iteration " << iteration_ + 1 << ": " << bad
                         << " Gaussian(s) had non-finite gradients; their "
                            "update was skipped";
  }

  if (!scene_.dynamics.opacities.empty()) {
    const auto start = Clock::now();
    PoseDynamicGaussiansBackward(scene_.dynamics, scene_.logits, scene_.bases,
                                 time, ns, grads_.means, grads_.quats,
                                 &dynamic_grads_.means, &dynamic_grads_.quats,
                                 &logit_grads_, &basis_grads_);
    times_.motion += Since(start);
  }
}

StepReport Trainer::Step() {
  strategy_.StepPreForward(iteration_, Optimised());
  StepReport report;
  const TrainingView& view = views_[NextView()];
  RenderView(view);
  ViewLosses(view, &report);
  if (!std::isfinite(report.loss)) return SkipStep(view, report);
  const auto start = Clock::now();
  const double motion_before = times_.motion;
  BackpropViewLosses(view);
  AddRefinementView(&report);
  AddRegularisers(&report);
  times_.backward += Since(start) - (times_.motion - motion_before);
  OptimiserStep(&report);
  ++iteration_;
  report.iteration = iteration_;
  const auto densify_start = Clock::now();
  strategy_.StepPostOptimise(iteration_, Optimised(), &rng_);
  times_.densify += Since(densify_start);
  return report;
}

void Trainer::RenderView(const TrainingView& view) {
  auto start = Clock::now();
  scene_.ComposeAt(view.time, &composed_);
  times_.compose += Since(start);
  start = Clock::now();
  rasterizer_.Forward(composed_, view.camera, Settings(), &out_, &state_);
  times_.forward += Since(start);
}

void Trainer::ViewLosses(const TrainingView& view, StepReport* report) {
  const auto start = Clock::now();
  const std::size_t view_index = &view - views_.data();
  // The photometric loss sees the render in the view's own colours (its
  // appearance transform), and carries the gradient back through it.
  const std::vector<float>* rendered = &out_.rgb;
  if (options_.appearance) {
    ApplyAppearance(appearance(view_index), out_.rgb, &corrected_);
    rendered = &corrected_;
  }
  const PhotometricLoss photo = ComputePhotometricLoss(
      *rendered, view.rgb, view.camera.width, view.camera.height,
      options_.ssim_weight, &d_out_.rgb, &loss_buffers_);
  if (options_.appearance) AppearanceBackward(view_index, report);
  report->l1 = photo.l1;
  report->ssim = photo.ssim;
  report->psnr = PsnrFromMse(photo.mse);
  d_out_.depth.clear();
  const float median = median_depth_[view_index];
  if (options_.depth_weight > 0 && !view.depth.empty() && median > 0) {
    report->depth = DepthL1Loss(out_.depth, view.depth, median,
                                options_.depth_weight, &d_out_.depth);
  }
  SurfaceLosses(view, report);
  PriorLosses(view, report);
  times_.loss += Since(start);
  report->loss = photo.total + report->depth + report->normal + report->hidden +
                 report->appearance + report->flow + report->disparity;
}

void Trainer::AppearanceBackward(std::size_t view_index, StepReport* report) {
  appearance_grads_.assign(appearance_.size(), 0.0f);
  float* d_transform = &appearance_grads_[view_index * kAppearanceWidth];
  ApplyAppearanceBackward(appearance(view_index), out_.rgb, d_out_.rgb,
                          &d_corrected_, d_transform);
  d_out_.rgb.swap(d_corrected_);
  report->appearance = AppearanceRegulariser(
      appearance(view_index), options_.appearance_weight, d_transform);
  // The reference frame keeps the identity: the Gaussians hold its colours
  // (a gain shared by every transform and the colours is otherwise free).
  if (view_index == kAppearanceReferenceView)
    std::fill_n(d_transform, kAppearanceWidth, 0.0f);
}

void Trainer::SurfaceLosses(const TrainingView& view, StepReport* report) {
  direct_grads_.means.clear();
  direct_grads_.log_scales.clear();
  direct_grads_.quats.clear();
  if (options_.normal_weight > 0 && !view.depth.empty()) {
    direct_grads_.log_scales.assign(composed_.log_scales.size(), 0.0f);
    direct_grads_.quats.assign(composed_.quats.size(), 0.0f);
    report->normal =
        NormalFlatnessLoss(composed_, view.camera, view.depth,
                           options_.normal_weight, options_.normal_tolerance,
                           &direct_grads_.log_scales, &direct_grads_.quats)
            .loss;
  }
  if (options_.hidden_weight > 0 && !view.depth.empty() &&
      !view.dynamic.empty() && scene_.dynamics.size() > 0) {
    direct_grads_.means.assign(composed_.means.size(), 0.0f);
    report->hidden =
        HiddenDepthLoss(composed_, scene_.statics.size(), view.camera,
                        view.depth, view.dynamic, options_.hidden_weight,
                        options_.hidden_thickness, &direct_grads_.means)
            .loss;
  }
}

StepReport Trainer::SkipStep(const TrainingView& view, StepReport report) {
  ++skipped_steps_total_;
  ++iteration_;
  report.iteration = iteration_;
  report.skipped_step = true;
  PANO4D_LOG(kWarning) << "fit: iteration " << iteration_ << " (view "
                       << view.name
                       << "): the loss is not finite; step skipped";
  return report;
}

void Trainer::BackpropViewLosses(const TrainingView& view) {
  static_grads_.Assign(scene_.statics);
  dynamic_grads_.Assign(scene_.dynamics);
  logit_grads_.assign(scene_.logits.size(), 0.0f);
  basis_grads_.num_bases = scene_.bases.num_bases;
  basis_grads_.num_times = scene_.bases.num_times;
  basis_grads_.rotations.assign(scene_.bases.rotations.size(), 0.0f);
  basis_grads_.translations.assign(scene_.bases.translations.size(), 0.0f);
  Backprop(view.camera, view.time, state_, out_, d_out_, &direct_grads_);
  PriorBackward();
  strategy_.StepPostBackward(state_, grads_);
}

void Trainer::AddRefinementView(StepReport* report) {
  if (!extra_view) return;
  const ExtraView* extra = extra_view(iteration_);
  if (extra == nullptr) return;
  scene_.ComposeAt(extra->time, &composed_);
  rasterizer_.Forward(composed_, extra->camera, Settings(), &extra_out_,
                      &extra_state_);
  if (const std::optional<double> loss =
          RefinementLoss(extra_out_.rgb, *extra, &d_extra_.rgb)) {
    report->extra = *loss;
    report->loss += report->extra;
    Backprop(extra->camera, extra->time, extra_state_, extra_out_, d_extra_);
  }
}

void Trainer::AddRegularisers(StepReport* report) {
  if (options_.anisotropy_weight > 0 && scene_.size() > 0) {
    const double norm = options_.anisotropy_weight / scene_.size();
    report->anisotropy =
        AnisotropyLoss(scene_.statics.log_scales, options_.max_anisotropy, norm,
                       &static_grads_.log_scales);
    report->anisotropy +=
        AnisotropyLoss(scene_.dynamics.log_scales, options_.max_anisotropy,
                       norm, &dynamic_grads_.log_scales);
    report->loss += report->anisotropy;
  }
  if (scene_.has_motion() && options_.smoothness_weight > 0) {
    report->smoothness = MotionSmoothnessLoss(
        scene_.bases, options_.smoothness_weight, &basis_grads_, extent_);
    report->loss += report->smoothness;
  }
}

void Trainer::OptimiserStep(StepReport* report) {
  const auto start = Clock::now();
  UpdateLearningRates();
  report->skipped_rows +=
      static_adam_
          .Step({&static_grads_.means, &static_grads_.log_scales,
                 &static_grads_.quats, &static_grads_.opacities,
                 &static_grads_.sh})
          .skipped_rows;
  if (scene_.has_motion()) {
    report->skipped_rows +=
        dynamic_adam_
            .Step({&dynamic_grads_.means, &dynamic_grads_.log_scales,
                   &dynamic_grads_.quats, &dynamic_grads_.opacities,
                   &dynamic_grads_.sh, &logit_grads_})
            .skipped_rows;
    report->skipped_rows +=
        basis_adam_.Step({&basis_grads_.rotations, &basis_grads_.translations})
            .skipped_rows;
  }
  if (options_.appearance) {
    report->skipped_rows +=
        appearance_adam_.Step({&appearance_grads_}).skipped_rows;
  }
  for (float& v : scene_.statics.log_scales)
    v = std::min(v, max_static_log_scale_);
  skipped_rows_total_ += report->skipped_rows;
  times_.optimise += Since(start);
}

void Trainer::PriorLosses(const TrainingView& view, StepReport* report) {
  flow_backward_.clear();
  if (options_.disparity_weight > 0 && !view.disparity.empty()) {
    if (d_out_.depth.empty()) d_out_.depth.assign(out_.depth.size(), 0.0f);
    const bool moving_only =
        options_.disparity_moving_only && !view.dynamic.empty();
    report->disparity =
        DisparityLoss(view.disparity, out_.depth, options_.disparity_weight,
                      &d_out_.depth, moving_only ? &view.dynamic : nullptr)
            .loss;
  }
  const std::size_t nd = scene_.dynamics.size();
  if (options_.flow_weight <= 0 || view.flows.empty() || nd == 0) return;
  if (direct_grads_.means.empty())
    direct_grads_.means.assign(composed_.means.size(), 0.0f);
  flow_posed_.sh_degree = scene_.dynamics.sh_degree;
  flow_posed_.Resize(nd);
  // The flow term is averaged over the view's flows.
  const double weight =
      options_.flow_weight / static_cast<double>(view.flows.size());
  for (const TrainingView::Flow& f : view.flows) {
    const TrainingView& other = views_[f.view];
    PoseDynamicGaussians(scene_.dynamics, scene_.logits, scene_.bases,
                         other.time, 0, &flow_posed_);
    FlowBackward& back = flow_backward_.emplace_back();
    back.time = other.time;
    back.d_means.assign(nd * 3, 0.0f);
    report->flow +=
        FlowLoss(composed_, scene_.statics.size(), flow_posed_.means,
                 view.camera, other.camera, f.flow, f.valid, out_.depth, weight,
                 options_.flow_tolerance, options_.flow_huber_pixels,
                 &direct_grads_.means, &back.d_means)
            .loss;
  }
}

void Trainer::PriorBackward() {
  if (flow_backward_.empty()) return;
  const auto start = Clock::now();
  flow_zero_quats_.assign(scene_.dynamics.size() * 4, 0.0f);
  for (const FlowBackward& back : flow_backward_) {
    PoseDynamicGaussiansBackward(scene_.dynamics, scene_.logits, scene_.bases,
                                 back.time, 0, back.d_means, flow_zero_quats_,
                                 &dynamic_grads_.means, &dynamic_grads_.quats,
                                 &logit_grads_, &basis_grads_);
  }
  times_.motion += Since(start);
}

std::int64_t Trainer::AddStaticGaussians(const GaussianModel& extra) {
  return strategy_.AddStatic(Optimised(), extra);
}

std::int64_t Trainer::RemoveStaticGaussians(
    const std::vector<std::uint8_t>& keep) {
  return strategy_.RemoveStatic(Optimised(), keep);
}

}  // namespace pano4d
