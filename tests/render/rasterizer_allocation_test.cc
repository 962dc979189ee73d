// Steady-state rendering does not allocate: every global operator new is
// counted, and a forward + backward on a warm rasterizer must not call it.
// A binary of its own, since it replaces operator new for the process.
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "src/render/bench_scene.h"
#include "src/render/rasterizer.h"

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace pano4d {
namespace {

TEST(RasterizerAllocationTest, WarmForwardAndBackwardDoNotAllocate) {
  const RasterCamera camera = BenchCamera(160, 120);
  const GaussianModel model = RandomViewFillingScene(20000, camera, 4, 7);
  Rasterizer rasterizer;
  RasterState state;
  RenderOutput out;
  GaussianGradients grad;
  RenderGradients d_out;
  const auto step = [&] {
    rasterizer.Forward(model, camera, {}, &out, &state);
    d_out.rgb.assign(out.rgb.size(), 0.1f);
    d_out.depth.assign(out.depth.size(), 0.01f);
    d_out.alpha.assign(out.alpha.size(), -0.2f);
    rasterizer.Backward(model, camera, {}, state, out, d_out, &grad);
  };
  step();  // sizes every buffer
  step();
  const long before = g_allocations.load();
  for (int i = 0; i < 3; ++i) step();
  EXPECT_EQ(g_allocations.load() - before, 0);
  // The step did real work.
  double norm = 0;
  for (const float g : grad.means) norm += std::abs(g);
  EXPECT_GT(norm, 0.0);
}

}  // namespace
}  // namespace pano4d
