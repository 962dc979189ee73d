#include "src/gs/strategy_options.h"

#include "src/core/option_checks.h"

namespace pano4d {

void StrategyOptions::Check() const {
  CheckPositive(densify_every, "fit options", "densify_every");
  CheckPositive(densify_gradient, "fit options", "densify_gradient");
  CheckPositive(percent_dense, "fit options", "percent_dense");
  CheckNonNegative(prune_opacity, "fit options", "prune_opacity");
  CheckPositive(max_screen_radius, "fit options", "max_screen_radius");
  CheckPositive(opacity_reset_every, "fit options", "opacity_reset_every");
  CheckPositive(static_cast<double>(max_gaussians), "fit options",
                "max_gaussians");
}

nlohmann::json StrategyOptions::ToJson() const {
  return {{"densify_from", densify_from},
          {"densify_until", densify_until},
          {"densify_every", densify_every},
          {"densify_gradient", densify_gradient},
          {"percent_dense", percent_dense},
          {"prune_opacity", prune_opacity},
          {"max_screen_radius", max_screen_radius},
          {"opacity_reset_every", opacity_reset_every},
          {"max_gaussians", max_gaussians}};
}

}  // namespace pano4d
