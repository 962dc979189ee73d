#include "src/gs/scene.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "src/core/error.h"

namespace pano4d {

void GaussianScene::Check() const {
  for (const auto& [model, name] :
       {std::pair{&statics, "statics."}, std::pair{&dynamics, "dynamics."}}) {
    try {
      model->CheckValues();
    } catch (const Error& e) {
      throw Error("scene", name + e.field(), e.value(), e.problem());
    }
  }
  bases.Check();
  if (statics.sh_degree != dynamics.sh_degree) {
    throw Error("scene", "sh_degree", std::to_string(dynamics.sh_degree),
                "static and dynamic Gaussians differ");
  }
  if (logits.size() != dynamics.size() * bases.num_bases ||
      (dynamics.size() > 0 && bases.empty())) {
    throw Error("scene", "logits", std::to_string(logits.size()),
                "expected " + std::to_string(dynamics.size()) + " x " +
                    std::to_string(bases.num_bases) +
                    " (dynamic Gaussians need motion bases)");
  }
  if (has_motion() && bases.num_times != num_times) {
    throw Error("scene", "bases times", std::to_string(bases.num_times),
                "expected " + std::to_string(num_times));
  }
  if (canonical_time < 0 || canonical_time >= num_times) {
    throw Error("scene", "canonical_time", std::to_string(canonical_time),
                "outside [0, " + std::to_string(num_times) + ")");
  }
}

void GaussianScene::ComposeAt(int time, GaussianModel* out) const {
  const std::size_t ns = statics.size(), nd = dynamics.size();
  out->sh_degree = statics.sh_degree;
  out->Resize(ns + nd);
  const auto copy = [](const std::vector<float>& s, const std::vector<float>& d,
                       std::vector<float>* o) {
    std::copy(s.begin(), s.end(), o->begin());
    std::copy(d.begin(), d.end(), o->begin() + s.size());
  };
  copy(statics.log_scales, dynamics.log_scales, &out->log_scales);
  copy(statics.opacities, dynamics.opacities, &out->opacities);
  copy(statics.sh, dynamics.sh, &out->sh);
  std::copy(statics.means.begin(), statics.means.end(), out->means.begin());
  std::copy(statics.quats.begin(), statics.quats.end(), out->quats.begin());
  if (nd > 0) PoseDynamicGaussians(dynamics, logits, bases, time, ns, out);
}

void AppendRows(const std::vector<std::uint32_t>& rows, int width,
                std::vector<float>* values) {
  const std::size_t old = values->size();
  values->resize(old + rows.size() * width);
  float* out = values->data() + old;
  for (std::uint32_t r : rows) {
    std::copy_n(values->data() + static_cast<std::size_t>(r) * width, width,
                out);
    out += width;
  }
}

void KeepRows(const std::vector<std::uint8_t>& keep, int width,
              std::vector<float>* values) {
  std::size_t w = 0;
  for (std::size_t r = 0; r < keep.size(); ++r) {
    if (!keep[r]) continue;
    if (w != r) {
      std::copy_n(values->data() + r * width, width,
                  values->data() + w * width);
    }
    ++w;
  }
  values->resize(w * width);
}

void AppendGaussianRows(const GaussianModel& from,
                        const std::vector<std::uint32_t>& rows,
                        GaussianModel* to) {
  const int k3 = to->sh_coefficients() * 3;
  const auto append = [&](const std::vector<float>& src, int width,
                          std::vector<float>* dst) {
    const std::size_t old = dst->size();
    dst->resize(old + rows.size() * width);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      std::copy_n(src.data() + static_cast<std::size_t>(rows[i]) * width, width,
                  dst->data() + old + i * width);
    }
  };
  append(from.means, 3, &to->means);
  append(from.log_scales, 3, &to->log_scales);
  append(from.quats, 4, &to->quats);
  append(from.opacities, 1, &to->opacities);
  append(from.sh, k3, &to->sh);
}

void KeepGaussianRows(const std::vector<std::uint8_t>& keep,
                      GaussianModel* model) {
  KeepRows(keep, 3, &model->means);
  KeepRows(keep, 3, &model->log_scales);
  KeepRows(keep, 4, &model->quats);
  KeepRows(keep, 1, &model->opacities);
  KeepRows(keep, model->sh_coefficients() * 3, &model->sh);
}

float InverseSigmoid(float p) {
  const float q = std::clamp(p, 1e-6f, 1.0f - 1e-6f);
  return std::log(q / (1.0f - q));
}

}  // namespace pano4d
