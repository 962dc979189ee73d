#pragma once

// The fit's convergence stop: the error against run time, sampled every few
// hundred iterations once the schedule's structural changes are over (the
// last expansion step distilled, densification ended), stops the fit when
// the last window of iterations gained less than a stated amount. More time
// then buys nothing the signal can see; `--iterations` turns it off.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace pano4d {

// What the stop reads. kAuto resolves (ResolveConvergeOn) to the held-out
// frames' PSNR when the fit has validation frames, else the training
// frames' PSNR. A held-out signal sees overfitting (on Balloon1 the
// training PSNR climbs 2 dB from iteration 1000 to 2000 while the held-out
// one gains 0.1); it also means the stopping iteration was chosen on those
// frames, which a protocol that keeps them unseen until the end forbids
// (use kTraining or --iterations there).
enum class ConvergeOn { kOff, kAuto, kValidation, kTraining };
const char* ConvergeOnName(ConvergeOn c);  // "off", "auto", "val", "train"
// Throws pano4d::Error naming --converge-on for anything else.
ConvergeOn ParseConvergeOn(const std::string& name);
// kAuto as the inputs decide; the others as they are.
ConvergeOn ResolveConvergeOn(ConvergeOn c, bool has_validation_frames);

struct ConvergenceOptions {
  // A sample of the signal every `every` iterations, from the first
  // multiple of `every` after the gate (ConvergenceGate).
  int every = 250;
  // Stop when the signal at iteration i is less than min_gain dB above
  // its sample at i - window. On Balloon1 the held-out PSNR gains 0.10 dB
  // from 1000 to 1250 iterations and nothing after
  // (docs/experiments/2026-12-02-budget-and-schedule.md).
  int window = 500;
  double min_gain = 0.05;

  void Check() const;  // throws pano4d::Error naming the flag
  nlohmann::json ToJson() const;
};

// The iteration after which samples are taken: that of the last
// structural change of the schedule, the last expansion step (0: none; it
// runs after that iteration's sample would be taken) or the end of
// densification, so that no window spans one.
std::int64_t ConvergenceGate(std::int64_t last_expansion_iteration,
                             std::int64_t densify_until);

// The rule over the samples, in iteration order. Pure: the fit feeds it and
// saves its samples with each checkpoint, so a resumed run decides as an
// uninterrupted one.
class ConvergenceRule {
 public:
  ConvergenceRule(ConvergenceOptions options, std::int64_t gate);

  // Whether a sample is due at iteration `it`.
  bool Due(std::int64_t it) const;
  // Adds the signal at `it` (a Due iteration; a non-finite value is not
  // kept and never stops the fit) and returns why the fit has converged,
  // or nothing.
  std::optional<std::string> Add(std::int64_t it, double psnr);

  // The samples, as (iteration, PSNR), and back: Restore keeps those at or
  // before `up_to` (a checkpoint's iteration) and re-decides on them.
  const std::vector<std::pair<std::int64_t, double>>& samples() const {
    return samples_;
  }
  void Restore(const std::vector<std::pair<std::int64_t, double>>& samples,
               std::int64_t up_to);
  // The reason of the last Add or Restore that converged (empty: none).
  const std::string& reason() const { return reason_; }
  std::int64_t gate() const { return gate_; }

 private:
  ConvergenceOptions options_;
  std::int64_t gate_;
  std::vector<std::pair<std::int64_t, double>> samples_;
  std::string reason_;
};

}  // namespace pano4d
