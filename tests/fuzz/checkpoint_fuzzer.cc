// Any bytes into the checkpoint readers: the scene and fingerprint readers,
// and a resume into a small trainer. A version 2 input gets its checksum
// recomputed first, so that mutations reach the header and array parsers
// rather than stopping at the checksum. Only pano4d::Error may come out.
//
// The seed: PANO4D_FUZZ_WRITE_SEED=PATH runs the same small trainer for two
// steps and writes its checkpoint to PATH (scripts/fuzz.sh does this), so
// the seed always has the current format and this trainer's fingerprints.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "src/core/error.h"
#include "src/core/hash.h"
#include "src/gs/trainer.h"
#include "src/render/bench_scene.h"

namespace {

constexpr int kSize = 16;

// Two views at two times; three static and two dynamic Gaussians with two
// motion bases, so that every array of a checkpoint has rows.
pano4d::Trainer* MakeTrainer() {
  using namespace pano4d;
  const RasterCamera camera = BenchCamera(kSize, kSize);
  GaussianScene scene;
  scene.statics = RandomViewFillingScene(3, camera, 3.0f, 1);
  scene.dynamics = RandomViewFillingScene(2, camera, 3.0f, 2);
  scene.num_times = 2;
  scene.bases.Reset(2, 2);
  scene.logits.assign(2 * 2, 0.0f);
  std::vector<TrainingView> views(2);
  for (int i = 0; i < 2; ++i) {
    views[i].name = "v" + std::to_string(i);
    views[i].time = i;
    views[i].camera = camera;
    views[i].rgb.assign(kSize * kSize * 3, 0.5f);
  }
  TrainerOptions options;
  options.iterations = 4;
  return new Trainer(scene, views, options, /*seed=*/0);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* path = std::getenv("PANO4D_FUZZ_WRITE_SEED")) {
    pano4d::Trainer* trainer = MakeTrainer();
    trainer->Step();
    trainer->Step();
    trainer->SaveCheckpoint(path);
    delete trainer;
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);
  if (size >= 24 && std::memcmp(data, "P4DCKPT2", 8) == 0) {
    pano4d::Hash64 sum;
    sum.Add(bytes.data(), size - 8);
    const std::uint64_t value = sum.value();
    std::memcpy(bytes.data() + size - 8, &value, 8);
  }
  try {
    (void)pano4d::ReadCheckpointFingerprint(bytes, "fuzz.ckpt");
  } catch (const pano4d::Error&) {
  }
  try {
    (void)pano4d::ReadCheckpointScene(bytes, "fuzz.ckpt");
  } catch (const pano4d::Error&) {
  }
  pano4d::Trainer* trainer = MakeTrainer();
  try {
    trainer->LoadCheckpoint(bytes, "fuzz.ckpt");
    trainer->Step();  // what was restored must train
  } catch (const pano4d::Error&) {
  }
  delete trainer;
  return 0;
}
