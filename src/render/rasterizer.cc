// RasterizerT: the stages composed (rasterizer.h), and the checks that a
// backward is given its own forward's state.
#include "src/render/rasterizer.h"

#include <algorithm>
#include <string>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/render/projection.h"
#include "src/render/rasterize_to_pixels.h"
#include "src/render/tile_intersection.h"

namespace pano4d {
namespace {

template <typename T>
void CheckCamera(const RasterCameraT<T>& camera) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw Error("rasterizer", "camera", SizeText(camera.width, camera.height),
                "image size must be positive");
  }
}

// The state, the forward's output and the output gradients must all be of
// the camera's image: anything else would be read out of bounds.
template <typename T>
void CheckBackwardInputs(const RasterCameraT<T>& camera,
                         const RasterStateT<T>& state,
                         const RenderOutputT<T>& out,
                         const RenderGradientsT<T>& d_out) {
  const std::size_t pixels =
      static_cast<std::size_t>(camera.width) * camera.height;
  PANO4D_CHECK(state.width == camera.width && state.height == camera.height &&
                   state.final_transmittance.size() == pixels &&
                   state.last_contributor.size() == pixels,
               "the rasterizer's backward got the state of a " +
                   SizeText(state.width, state.height) + " forward for a " +
                   SizeText(camera.width, camera.height) + " camera");
  PANO4D_CHECK(out.width == camera.width && out.height == camera.height &&
                   out.depth.size() == pixels,
               "the rasterizer's backward got the output of a " +
                   SizeText(out.width, out.height) + " forward for a " +
                   SizeText(camera.width, camera.height) + " camera");
  const auto check = [&](const std::vector<T>& d, std::size_t per,
                         const char* name) {
    PANO4D_CHECK(d.empty() || d.size() == per * pixels,
                 std::string("the rasterizer's backward got ") +
                     std::to_string(d.size()) + " values of the gradient of " +
                     name + ", not " + std::to_string(per * pixels) +
                     " for a " + SizeText(camera.width, camera.height) +
                     " image, or none");
  };
  check(d_out.rgb, 3, "rgb");
  check(d_out.depth, 1, "depth");
  check(d_out.alpha, 1, "alpha");
}

}  // namespace

template <typename T>
void RasterizerT<T>::Intersect(const RasterCameraT<T>& camera,
                               RasterStateT<T>* state) {
  state->width = camera.width;
  state->height = camera.height;
  IntersectTiles(&sort_, state);
  state->stats.tile_entries = state->sorted_ids.size();
}

template <typename T>
void RasterizerT<T>::Forward(const GaussianModelT<T>& model,
                             const RasterCameraT<T>& camera,
                             const RasterSettingsT<T>& settings,
                             RenderOutputT<T>* out, RasterStateT<T>* state) {
  model.Check();
  CheckCamera(camera);
  RasterStats& stats = state->stats;
  Timer timer;
  ProjectionForward(model, camera, &state->projected);
  stats.project_ms = 1e3 * timer.WallSeconds();
  timer.Restart();
  Intersect(camera, state);
  stats.bin_ms = 1e3 * timer.WallSeconds();
  const std::vector<int>& radius = state->projected.radius;
  stats.visible = static_cast<std::uint64_t>(
      std::count_if(radius.begin(), radius.end(), [](int r) { return r > 0; }));
  timer.Restart();
  stats.pixel_evaluations = RasterizeToPixelsForward(settings, state, out);
  stats.blend_ms = 1e3 * timer.WallSeconds();
}

template <typename T>
RasterBackwardStats RasterizerT<T>::Backward(const GaussianModelT<T>& model,
                                             const RasterCameraT<T>& camera,
                                             const RasterSettingsT<T>& settings,
                                             const RasterStateT<T>& state,
                                             const RenderOutputT<T>& out,
                                             const RenderGradientsT<T>& d_out,
                                             GaussianGradientsT<T>* grad) {
  PANO4D_CHECK(model.size() == state.gaussians(),
               "the rasterizer's backward got " + std::to_string(model.size()) +
                   " Gaussians for a forward that projected " +
                   std::to_string(state.gaussians()));
  RasterBackwardStats stats;
  Timer timer;
  stats.pixel_evaluations =
      RasterizeBackward(camera, settings, state, out, d_out, &grad2d_);
  stats.blend_ms = 1e3 * timer.WallSeconds();
  timer.Restart();
  ProjectionBackward(model, camera, state.projected, grad2d_, grad);
  stats.project_ms = 1e3 * timer.WallSeconds();
  return stats;
}

template <typename T>
void RasterizerT<T>::Render(const GaussianModelT<T>& model,
                            const RasterCameraT<T>& camera,
                            const RasterSettingsT<T>& settings,
                            RenderOutputT<T>* out) {
  Forward(model, camera, settings, out, &render_state_);
}

template <typename T>
void RasterizerT<T>::RasterizeForward(const ProjectedGaussiansT<T>& projected,
                                      const RasterCameraT<T>& camera,
                                      const RasterSettingsT<T>& settings,
                                      RenderOutputT<T>* out,
                                      RasterStateT<T>* state) {
  CheckCamera(camera);
  state->projected = projected;
  Intersect(camera, state);
  state->stats.pixel_evaluations =
      RasterizeToPixelsForward(settings, state, out);
}

template <typename T>
std::uint64_t RasterizerT<T>::RasterizeBackward(
    const RasterCameraT<T>& camera, const RasterSettingsT<T>& settings,
    const RasterStateT<T>& state, const RenderOutputT<T>& out,
    const RenderGradientsT<T>& d_out, ProjectedGradientsT<T>* grad2d) {
  CheckBackwardInputs(camera, state, out, d_out);
  return RasterizeToPixelsBackward(settings, state, out, d_out, &entry_grads_,
                                   grad2d);
}

template class RasterizerT<float>;
template class RasterizerT<double>;

}  // namespace pano4d
