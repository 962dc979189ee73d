#include "src/pipeline/eval.h"

#include <cstdlib>

namespace pano4d {
namespace fs = std::filesystem;

EvalSummary RunEval(const EvalOptions& options) {
  const Dataset dataset = LoadDataset(options.dataset, options.factor);
  EvalSummary s;
  s.result = EvaluateRenders(dataset, options.renders,
                             {options.split, options.lpips_weights});
  s.out = options.out.empty() ? options.renders / "metrics" : options.out;
  s.markdown = WriteEvaluation(s.result, s.out, DatasetsMetaDir());
  return s;
}

fs::path DatasetsMetaDir() {
  const char* env = std::getenv("PANO4D_DATASETS_META");
  return env ? fs::path(env) : fs::path(PANO4D_DATASETS_META_DIR);
}

Dataset ValidationDataset(const Workspace& ws, const WorkspaceFrames& frames) {
  // The ground truth of record: the dataset the frames came from.
  if (!frames.dataset.empty())
    return LoadDataset(frames.dataset, frames.dataset_factor);
  Dataset dataset;
  dataset.kind = DatasetKind::kHeldOut;
  dataset.root = ws.root();
  dataset.scene =
      fs::absolute(ws.root()).lexically_normal().filename().string();
  dataset.factor = 1;
  dataset.num_times = frames.num_times;
  for (const WorkspaceFrame& f : frames.val) {
    DatasetFrame d;
    d.id = f.name;
    d.time_id = f.time;
    d.camera = f.camera;
    d.rgb = f.rgb;
    d.covisible = f.covisible;
    dataset.val.push_back(d);
  }
  return dataset;
}

}  // namespace pano4d
