#include "src/gs/trainer_options.h"

#include <cmath>
#include <string>
#include <utility>

#include "src/core/error.h"
#include "src/core/option_checks.h"

namespace pano4d {

void TrainerOptions::Check() const {
  const auto positive = [](double v, const char* name) {
    CheckPositive(v, "fit options", name);
  };
  const auto non_negative = [](double v, const char* name) {
    CheckNonNegative(v, "fit options", name);
  };
  const auto weight = [&](double v, const char* name) {
    non_negative(v, name);
    if (v > kMaxLossWeight) {
      throw Error("fit options", name, std::to_string(v),
                  "must be at most 10000 (the photometric term's weight is "
                  "1)");
    }
  };
  positive(iterations, "iterations");
  if (!(ssim_weight >= 0 && ssim_weight <= 1)) {
    throw Error("fit options", "ssim_weight", std::to_string(ssim_weight),
                "must be in [0, 1]");
  }
  weight(depth_weight, "depth_weight");
  weight(smoothness_weight, "smoothness_weight");
  weight(anisotropy_weight, "anisotropy_weight");
  weight(normal_weight, "normal_weight");
  weight(hidden_weight, "hidden_weight");
  non_negative(hidden_thickness, "hidden_thickness");
  weight(appearance_weight, "appearance_weight");
  positive(normal_tolerance, "normal_tolerance");
  weight(flow_weight, "flow_weight");
  positive(flow_tolerance, "flow_tolerance");
  positive(flow_huber_pixels, "flow_huber_pixels");
  weight(disparity_weight, "disparity_weight");
  if (!(max_anisotropy >= 1)) {
    throw Error("fit options", "max_anisotropy", std::to_string(max_anisotropy),
                "must be at least 1");
  }
  for (auto [v, name] : {std::pair{lr_mean, "lr_mean"},
                         {lr_log_scale, "lr_log_scale"},
                         {lr_quat, "lr_quat"},
                         {lr_opacity, "lr_opacity"},
                         {lr_sh, "lr_sh"},
                         {lr_logit, "lr_logit"},
                         {lr_basis_rotation, "lr_basis_rotation"},
                         {lr_basis_translation, "lr_basis_translation"},
                         {lr_appearance, "lr_appearance"}})
    non_negative(v, name);
  non_negative(max_static_scale_pixels, "max_static_scale_pixels");
  strategy.Check();
}

nlohmann::json TrainerOptions::ToJson() const {
  nlohmann::json j = {
      {"iterations", iterations},
      {"ssim_weight", ssim_weight},
      {"depth_weight", depth_weight},
      {"smoothness_weight", smoothness_weight},
      {"anisotropy_weight", anisotropy_weight},
      {"max_anisotropy", max_anisotropy},
      {"normal_weight", normal_weight},
      {"normal_tolerance", normal_tolerance},
      {"hidden_weight", hidden_weight},
      {"hidden_thickness", hidden_thickness},
      {"flow_weight", flow_weight},
      {"flow_tolerance", flow_tolerance},
      {"flow_huber_pixels", flow_huber_pixels},
      {"disparity_weight", disparity_weight},
      {"disparity_moving_only", disparity_moving_only},
      {"appearance", appearance},
      {"appearance_weight", appearance_weight},
      {"lr_appearance", lr_appearance},
      {"lr_mean", lr_mean},
      {"lr_log_scale", lr_log_scale},
      {"lr_quat", lr_quat},
      {"lr_opacity", lr_opacity},
      {"lr_sh", lr_sh},
      {"lr_logit", lr_logit},
      {"lr_basis_rotation", lr_basis_rotation},
      {"lr_basis_translation", lr_basis_translation},
      {"max_static_scale_pixels", max_static_scale_pixels},
      {"background", {background.x(), background.y(), background.z()}}};
  j.update(strategy.ToJson());
  return j;
}

}  // namespace pano4d
