#include "src/pipeline/fit_summary.h"

#include <cstdio>
#include <string>

#include "src/core/strings.h"

namespace pano4d {
namespace {

std::string Value(const std::optional<double>& v) {
  return v ? StringPrintf("%.3f", *v) : "n/a";
}

std::optional<double> Metric(const MetricRow& row, const char* key) {
  for (std::size_t i = 0; i < kNumMetrics; ++i)
    if (std::string(kMetricKeys[i]) == key) return row[i];
  return std::nullopt;
}

std::optional<double> Mean(const EvaluationResult& e, const char* key) {
  return Metric(e.mean, key);
}

}  // namespace

const char* FitTerminationName(FitTermination t) {
  switch (t) {
    case FitTermination::kIterationsDone:
      return "iterations done";
    case FitTermination::kTimeBudget:
      return "time budget";
    case FitTermination::kStopped:
      return "stopped";
    case FitTermination::kConverged:
      return "converged";
  }
  return "unknown";
}

std::string FitSummary::BriefReport() const {
  std::string s = StringPrintf(
      "pano4d fit: %lld iterations (%s), %zu Gaussians, train PSNR %.2f dB",
      static_cast<long long>(iterations), FitTerminationName(termination),
      static_gaussians + dynamic_gaussians, train_psnr);
  if (evaluation) {
    s += ", validation PSNR " + Value(Mean(*evaluation, "psnr")) + " mPSNR " +
         Value(Mean(*evaluation, "mpsnr"));
  }
  return s + StringPrintf(", %.1f s", seconds.total);
}

std::string FitSummary::FullReport() const {
  const PhaseTimes& t = seconds.trainer;
  std::string s = "\npano4d fit report\n";
  s += StringPrintf("  %-22s %lld", "iterations",
                    static_cast<long long>(iterations));
  if (resumed_at > 0)
    s += StringPrintf(" (resumed at %lld)", static_cast<long long>(resumed_at));
  if (termination == FitTermination::kTimeBudget)
    s += " (stopped by the time budget)";
  if (termination == FitTermination::kStopped) s += " (stopped)";
  if (termination == FitTermination::kConverged) {
    s += " (converged on " + convergence.value("signal", std::string()) + ": " +
         convergence.value("reason", std::string()) + ")";
  }
  s += StringPrintf("\n  %-22s static %zu, dynamic %zu, motion bases %d\n",
                    "Gaussians", static_gaussians, dynamic_gaussians,
                    motion_bases);
  s += StringPrintf("  %-22s %lld densified, %lld pruned\n", "densification",
                    static_cast<long long>(densified),
                    static_cast<long long>(pruned));
  s +=
      StringPrintf("  %-22s %lld Gaussian updates, %lld steps\n",
                   "skipped (non-finite)", static_cast<long long>(skipped_rows),
                   static_cast<long long>(skipped_steps));
  s += StringPrintf(
      "  %-22s %.1f s: init %.1f, forward %.1f, loss %.1f, backward %.1f, "
      "motion %.1f, optimiser %.1f, densify %.1f, compose %.1f, validation "
      "%.1f\n",
      "time", seconds.total, seconds.init, t.forward, t.loss, t.backward,
      t.motion, t.optimise, t.densify, t.compose, seconds.validation);
  if (expanded) {
    s += StringPrintf(
        "  %-22s %zu steps, %.1f s, %zu refinement views, %lld layout "
        "shell Gaussians, %lld static Gaussians in seen free space "
        "removed%s\n",
        "expansion", expansion_steps.size(), seconds.expansion,
        refinement_views, static_cast<long long>(layout_shell.gaussians),
        static_cast<long long>(carved),
        panorama_only ? " (validation: the panorama results)" : "");
  } else {
    s += StringPrintf("  %-22s none (%s)\n", "expansion",
                      no_expansion_reason.c_str());
  }
  const StepReport& l = last_step;
  s += StringPrintf(
      "  %-22s %.5f (L1 %.5f, SSIM %.4f, depth %.5f, normal %.5f, "
      "hidden %.5f)\n",
      "last loss", l.loss, l.l1, l.ssim, l.depth, l.normal, l.hidden);
  s += StringPrintf("  %-22s %.3f dB over %zu training frames\n", "train PSNR",
                    train_psnr, train_frames);
  if (!validation_appearance.empty()) {
    s += StringPrintf("  %-22s validation renders take %s", "appearance",
                      validation_appearance.c_str());
    if (val_psnr_without_appearance)
      s += StringPrintf("; PSNR %.3f without it", *val_psnr_without_appearance);
    s += "\n";
  }
  if (evaluation) {
    const EvaluationResult& e = *evaluation;
    s += StringPrintf(
        "  %-22s PSNR %s  SSIM %s  mPSNR %s  mSSIM %s  uPSNR %s  uSSIM %s "
        "(%zu frames)\n",
        "validation", Value(Mean(e, "psnr")).c_str(),
        Value(Mean(e, "ssim")).c_str(), Value(Mean(e, "mpsnr")).c_str(),
        Value(Mean(e, "mssim")).c_str(), Value(Mean(e, "upsnr")).c_str(),
        Value(Mean(e, "ussim")).c_str(), val_frames);
    if (e.floor && Mean(e, "upsnr")) {
      s += StringPrintf("  %-22s uPSNR %s (the mean training colour's)\n",
                        "floor", Value(Metric(e.floor->mean, "upsnr")).c_str());
    }
    s += StringPrintf("  %-22s %s\n", "metrics",
                      workspace.metrics_json().c_str());
  }
  s += StringPrintf("  %-22s %s\n  %-22s %s\n", "run log",
                    workspace.fit_csv().c_str(), "checkpoint",
                    workspace.checkpoint().c_str());
  return s;
}

nlohmann::json FitSummary::ToJson() const {
  const PhaseTimes& t = seconds.trainer;
  nlohmann::json metrics;
  if (evaluation) metrics = EvaluationJson(*evaluation).value("mean", metrics);
  return {
      {"iterations", iterations},
      {"termination", FitTerminationName(termination)},
      {"convergence", convergence},
      {"resumed_at", resumed_at},
      {"stopped_by_time_budget", termination == FitTermination::kTimeBudget},
      {"deterministic", used.deterministic},
      {"seed", used.seed},
      {"depth_source", depth_source},
      {"priors", priors},
      {"static_gaussians", static_gaussians},
      {"dynamic_gaussians", dynamic_gaussians},
      {"motion_bases", motion_bases},
      {"densified", densified},
      {"pruned", pruned},
      {"skipped_gaussian_updates", skipped_rows},
      {"skipped_steps", skipped_steps},
      {"init", resumed_at > 0 ? nlohmann::json() : init.ToJson()},
      {"seconds",
       {{"total", seconds.total},
        {"init", seconds.init},
        {"compose", t.compose},
        {"forward", t.forward},
        {"loss", t.loss},
        {"backward", t.backward},
        {"motion", t.motion},
        {"optimise", t.optimise},
        {"densify", t.densify},
        {"validation", seconds.validation},
        {"expansion", seconds.expansion}}},
      {"expansion",
       expanded ? nlohmann::json{{"options", used.expansion.ToJson()},
                                 {"prior_cmd", used.prior_cmd},
                                 {"steps", expansion_steps},
                                 {"carved", carved},
                                 {"layout_planes", layout_shell.planes},
                                 {"layout_shell", layout_shell.gaussians}}
                : nlohmann::json()},
      {"final_loss", last_step.loss},
      {"train_psnr", train_psnr},
      {"appearance",
       validation_appearance.empty()
           ? nlohmann::json()
           : nlohmann::json{{"validation", validation_appearance},
                            {"val_psnr_without",
                             val_psnr_without_appearance
                                 ? nlohmann::json(*val_psnr_without_appearance)
                                 : nlohmann::json()}}},
      {"options", trainer_options.ToJson()},
      {"options_given", given.ToJson()},
      {"options_used", used.ToJson()},
      {"metrics", metrics}};
}

}  // namespace pano4d
