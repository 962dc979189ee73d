#include "src/pipeline/priors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/log.h"
#include "src/core/strings.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Image files `pano4d sfm` may have written to WS/images.
bool IsImage(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

PriorFrame PriorFrameOf(const WorkspaceFrame& f, bool used) {
  return {f.name, f.rgb, f.camera.camera.width, f.camera.camera.height, used};
}

// "a, b, c and 4 more", for logs.
std::string NameList(const std::vector<std::string>& names) {
  constexpr std::size_t kShown = 4;
  std::string text;
  for (std::size_t i = 0; i < names.size() && i < kShown; ++i)
    text += (i ? ", " : "") + names[i];
  if (names.size() > kShown)
    text += " and " + std::to_string(names.size() - kShown) + " more";
  return text;
}

}  // namespace

std::vector<PriorFrame> PriorVideoFrames(const Workspace& ws,
                                         const WorkspaceFrames& frames) {
  std::vector<const WorkspaceFrame*> train;
  for (const WorkspaceFrame& f : frames.train) train.push_back(&f);
  std::sort(train.begin(), train.end(), [](auto* a, auto* b) {
    return a->time != b->time ? a->time < b->time
                              : NaturalLess(a->name, b->name);
  });
  std::vector<PriorFrame> video;
  std::vector<fs::path> images;
  if (frames.dataset.empty() && fs::is_directory(ws.images())) {
    for (const fs::directory_entry& e : fs::directory_iterator(ws.images()))
      if (e.is_regular_file() && IsImage(e.path())) images.push_back(e.path());
    std::sort(images.begin(), images.end(), [](auto& a, auto& b) {
      return NaturalLess(a.filename().string(), b.filename().string());
    });
  }
  if (images.empty()) {
    // A dataset's training frames are its video.
    for (const WorkspaceFrame* f : train)
      video.push_back(PriorFrameOf(*f, true));
    return video;
  }
  std::map<std::string, const WorkspaceFrame*> by_file;
  for (const WorkspaceFrame* f : train) by_file[f->rgb.filename().string()] = f;
  for (const fs::path& image : images) {
    const auto it = by_file.find(image.filename().string());
    if (it != by_file.end()) {
      video.push_back(PriorFrameOf(*it->second, true));
      continue;
    }
    // Held out or not posed: its files are known, not read.
    PriorFrame unused = PriorFrameOf(*train.front(), false);
    unused.name = image.stem().string();
    unused.image = image;
    video.push_back(unused);
  }
  return video;
}

namespace {

// The training view of each video frame, -1 where it has none.
std::vector<int> TrainingViewOfVideo(const std::vector<PriorFrame>& video,
                                     const WorkspaceFrames& frames) {
  std::map<std::string, int> view_of;
  for (std::size_t i = 0; i < frames.train.size(); ++i)
    view_of[frames.train[i].name] = static_cast<int>(i);
  std::vector<int> view_at(video.size(), -1);
  for (std::size_t j = 0; j < video.size(); ++j) {
    const auto it = view_of.find(video[j].name);
    if (it != view_of.end() && video[j].used) view_at[j] = it->second;
  }
  return view_at;
}

// Each training view's disparity (metric depth inverted; NaN where none).
nlohmann::json AttachDisparity(const DepthPrior& depth,
                               const std::vector<PriorFrame>& video,
                               const std::vector<int>& view_at,
                               std::vector<TrainingView>* views) {
  std::vector<std::string> without;
  for (std::size_t j = 0; j < video.size(); ++j) {
    const int v = view_at[j];
    if (v < 0) continue;
    const cv::Mat& map = depth.maps[j];
    if (map.empty()) {
      without.push_back(video[j].name);
      continue;
    }
    std::vector<float>& out = (*views)[v].disparity;
    out.assign(map.total(), std::numeric_limits<float>::quiet_NaN());
    const bool metric = depth.layout->meaning == DepthMeaning::kMetricDepth;
    for (std::size_t p = 0; p < map.total(); ++p) {
      const float d = map.ptr<float>()[p];
      if (!metric)
        out[p] = d;
      else if (d > 0)
        out[p] = 1.0f / d;
    }
  }
  if (!without.empty()) {
    PANO4D_LOG(kInfo) << "fit: no learned depth for frame(s) "
                      << NameList(without);
  }
  return {{"layout", depth.layout->name}, {"frames_without", without}};
}

// The flow fields between training views, on the view they start from.
nlohmann::json AttachFlow(const FlowPrior& flow,
                          const std::vector<int>& view_at,
                          std::vector<TrainingView>* views) {
  int pairs = 0;
  std::map<std::string, int> masks;
  for (const FlowField& field : flow.fields) {
    const int a = view_at[field.from], b = view_at[field.to];
    if (a < 0 || b < 0) continue;
    TrainingView& view = (*views)[a];
    TrainingView::Flow& f = view.flows.emplace_back();
    f.view = b;
    f.flow.assign(field.flow.ptr<float>(),
                  field.flow.ptr<float>() + field.flow.total() * 2);
    f.valid.assign(field.valid.ptr<std::uint8_t>(),
                   field.valid.ptr<std::uint8_t>() + field.valid.total());
    ++pairs;
    ++masks[field.mask_source];
  }
  std::vector<std::string> without;
  for (std::size_t i = 0; i < views->size(); ++i)
    if ((*views)[i].flows.empty()) without.push_back((*views)[i].name);
  PANO4D_LOG(kInfo) << "fit: flow from " << flow.layout->name << ": " << pairs
                    << " pairs of neighbouring training frames"
                    << (without.empty() ? ""
                                        : "; none from " + NameList(without));
  return {{"layout", flow.layout->name},
          {"pairs", pairs},
          {"masks", masks},
          {"frames_without", without}};
}

// The tracks over the frames' times (from the video's frames), and the
// training view at each time (-1: none).
Tracks2D TracksOverTime(const TrackPrior& tracks,
                        const std::vector<int>& view_at, int num_times,
                        const std::vector<TrainingView>& views,
                        std::vector<int>* view_of_time) {
  const int n = static_cast<int>(tracks.size());
  Tracks2D over_time;
  over_time.num_times = num_times;
  over_time.pixels.assign(static_cast<std::size_t>(n) * num_times,
                          Eigen::Vector2f::Zero());
  over_time.valid.assign(over_time.pixels.size(), 0);
  view_of_time->assign(num_times, -1);
  for (std::size_t j = 0; j < view_at.size(); ++j) {
    const int v = view_at[j];
    if (v < 0) continue;
    const int t = views[v].time;
    (*view_of_time)[t] = v;
    for (int k = 0; k < n; ++k) {
      over_time.pixels[k * num_times + t] =
          tracks.pixels[k * tracks.num_frames + j];
      over_time.valid[k * num_times + t] =
          tracks.visible[k * tracks.num_frames + j];
    }
  }
  return over_time;
}

// Sparse flow from the tracks between views kTrackFlowGaps apart in time,
// where no dense flow joins them. Returns the pairs added.
int AddSparseFlow(const Tracks2D& over_time,
                  const std::vector<int>& view_of_time,
                  std::vector<TrainingView>* views) {
  const int num_times = over_time.num_times;
  const int n = static_cast<int>(over_time.size());
  int pairs = 0;
  for (int ta = 0; ta < num_times; ++ta) {
    const int a = view_of_time[ta];
    if (a < 0) continue;
    TrainingView& va = (*views)[a];
    const int w = va.camera.width, h = va.camera.height;
    for (const int gap : kTrackFlowGaps) {
      for (const int tb : {ta - gap, ta + gap}) {
        if (tb < 0 || tb >= num_times || view_of_time[tb] < 0) continue;
        const int b = view_of_time[tb];
        if (std::any_of(
                va.flows.begin(), va.flows.end(),
                [&](const TrainingView::Flow& f) { return f.view == b; }))
          continue;
        TrainingView::Flow f;
        f.view = b;
        f.flow.assign(static_cast<std::size_t>(w) * h * 2, 0.0f);
        f.valid.assign(static_cast<std::size_t>(w) * h, 0);
        int used = 0;
        for (int k = 0; k < n; ++k) {
          const std::size_t ka = k * num_times + ta;
          const std::size_t kb = k * num_times + tb;
          if (!over_time.valid[ka] || !over_time.valid[kb]) continue;
          const Eigen::Vector2f pa = over_time.pixels[ka];
          const int x = static_cast<int>(std::floor(pa.x()));
          const int y = static_cast<int>(std::floor(pa.y()));
          if (x < 0 || y < 0 || x >= w || y >= h) continue;
          const std::size_t p = static_cast<std::size_t>(y) * w + x;
          const Eigen::Vector2f d = over_time.pixels[kb] - pa;
          f.flow[2 * p] = d.x();
          f.flow[2 * p + 1] = d.y();
          f.valid[p] = kMaskOn;
          ++used;
        }
        if (used == 0) continue;
        va.flows.push_back(std::move(f));
        ++pairs;
      }
    }
  }
  return pairs;
}

}  // namespace

nlohmann::json AttachPriors(const PriorsFolder& folder,
                            const std::vector<PriorFrame>& video,
                            const WorkspaceFrames& frames,
                            std::vector<TrainingView>* views,
                            Tracks2D* tracks_out) {
  const std::vector<int> view_at = TrainingViewOfVideo(video, frames);
  nlohmann::json report = nlohmann::json::object();
  // Track files carry no size: they are taken at the other priors'.
  int source_w = 0, source_h = 0;
  if (const std::optional<DepthPrior> depth = ReadDepthPrior(folder, video)) {
    source_w = depth->source_width;
    source_h = depth->source_height;
    report["disparity"] = AttachDisparity(*depth, video, view_at, views);
  }
  if (const std::optional<FlowPrior> flow = ReadFlowPrior(folder, video)) {
    if (source_w == 0) {
      source_w = flow->source_width;
      source_h = flow->source_height;
    }
    report["flow"] = AttachFlow(*flow, view_at, views);
  }
  if (const std::optional<TrackPrior> tracks =
          ReadTrackPrior(folder, video, source_w, source_h)) {
    std::vector<int> view_of_time;
    Tracks2D over_time = TracksOverTime(*tracks, view_at, frames.num_times,
                                        *views, &view_of_time);
    const int pairs = AddSparseFlow(over_time, view_of_time, views);
    const int n = static_cast<int>(tracks->size());
    report["tracks"] = {{"layout", tracks->layout->name},
                        {"tracks", n},
                        {"sparse_flow_pairs", pairs}};
    PANO4D_LOG(kInfo) << "fit: " << n << " tracks from " << tracks->layout->name
                      << "; sparse flow for " << pairs
                      << " pairs of training frames";
    if (tracks_out) *tracks_out = std::move(over_time);
  }
  return report;
}

std::vector<std::string> DescribePriorUse(const PriorsFolder& folder,
                                          const std::string& depth_instead) {
  std::vector<std::string> lines;
  for (const PriorKind kind : {PriorKind::kDepth, PriorKind::kFlow,
                               PriorKind::kTracks, PriorKind::kMasks}) {
    const std::vector<const PriorLayout*> layouts = folder.Of(kind);
    for (std::size_t i = 0; i < layouts.size(); ++i) {
      const PriorLayout& l = *layouts[i];
      std::string use;
      if (i > 0) {
        use = "not used: " + layouts.front()->name + " is read instead";
      } else if (kind == PriorKind::kDepth && !depth_instead.empty()) {
        use = "its depth not used: the run takes " + depth_instead +
              "; the fit's disparity loss (--disparity-weight) uses it";
      } else if (kind == PriorKind::kDepth) {
        use = std::string(l.meaning == DepthMeaning::kMetricDepth
                              ? "scaled"
                              : "aligned (affine in inverse depth)") +
              " to the SfM points per frame: depth of the moving pixels "
              "(rescaled along the flow, when there is flow, to be "
              "consistent between frames) and of static pixels without "
              "stereo support; the fit's disparity loss";
      } else if (kind == PriorKind::kFlow) {
        use =
            "the motion's initial tracks (chained from the canonical "
            "frame) and the flow loss on the dynamic Gaussians";
      } else if (kind == PriorKind::kTracks) {
        use =
            "the motion's initial tracks (those seen at the canonical "
            "frame) and, between frames 1 or 2 apart without dense flow, "
            "the flow loss at the tracks' pixels";
      } else {
        use = "the dynamic masks";
      }
      lines.push_back(std::string(PriorKindName(kind)) + ": " + l.name + " (" +
                      std::to_string(l.files) + " file" +
                      (l.files == 1 ? "" : "s") + "): " + use);
    }
  }
  return lines;
}

}  // namespace pano4d
