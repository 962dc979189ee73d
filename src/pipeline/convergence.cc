#include "src/pipeline/convergence.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "src/core/error.h"
#include "src/core/option_checks.h"

namespace pano4d {

const char* ConvergeOnName(ConvergeOn c) {
  switch (c) {
    case ConvergeOn::kOff:
      return "off";
    case ConvergeOn::kAuto:
      return "auto";
    case ConvergeOn::kValidation:
      return "val";
    case ConvergeOn::kTraining:
      return "train";
  }
  return "?";
}

ConvergeOn ParseConvergeOn(const std::string& name) {
  for (ConvergeOn c : {ConvergeOn::kOff, ConvergeOn::kAuto,
                       ConvergeOn::kValidation, ConvergeOn::kTraining})
    if (name == ConvergeOnName(c)) return c;
  throw Error("--converge-on", "", name, "use auto, val, train or off");
}

ConvergeOn ResolveConvergeOn(ConvergeOn c, bool has_validation_frames) {
  if (c != ConvergeOn::kAuto) return c;
  return has_validation_frames ? ConvergeOn::kValidation
                               : ConvergeOn::kTraining;
}

void ConvergenceOptions::Check() const {
  CheckPositive(every, "fit options", "--converge-every");
  CheckPositive(window, "fit options", "--converge-window");
  CheckNonNegative(min_gain, "fit options", "--converge-min-gain");
  if (window % every != 0) {
    throw Error("--converge-window", "", std::to_string(window),
                "must be a multiple of --converge-every (" +
                    std::to_string(every) +
                    "): the rule compares two of its samples");
  }
}

nlohmann::json ConvergenceOptions::ToJson() const {
  return {{"every", every}, {"window", window}, {"min_gain", min_gain}};
}

std::int64_t ConvergenceGate(std::int64_t last_expansion_iteration,
                             std::int64_t densify_until) {
  return std::max<std::int64_t>({0, last_expansion_iteration, densify_until});
}

ConvergenceRule::ConvergenceRule(ConvergenceOptions options, std::int64_t gate)
    : options_(options), gate_(gate) {}

bool ConvergenceRule::Due(std::int64_t it) const {
  return it > gate_ && it % options_.every == 0;
}

std::optional<std::string> ConvergenceRule::Add(std::int64_t it, double psnr) {
  if (!std::isfinite(psnr)) return std::nullopt;
  samples_.emplace_back(it, psnr);
  const auto before = std::find_if(
      samples_.begin(), samples_.end(),
      [&](const auto& s) { return s.first == it - options_.window; });
  if (before == samples_.end()) return std::nullopt;
  const double gain = psnr - before->second;
  if (!(gain < options_.min_gain)) return std::nullopt;
  std::ostringstream why;
  why.setf(std::ios::fixed);
  why.precision(3);
  why << "PSNR " << psnr << " dB gained " << gain << " dB over the last "
      << options_.window << " iterations (less than " << options_.min_gain
      << ")";
  reason_ = why.str();
  return reason_;
}

void ConvergenceRule::Restore(
    const std::vector<std::pair<std::int64_t, double>>& samples,
    std::int64_t up_to) {
  samples_.clear();
  reason_.clear();
  for (const auto& [it, psnr] : samples)
    if (it <= up_to && Due(it)) Add(it, psnr);
}

}  // namespace pano4d
