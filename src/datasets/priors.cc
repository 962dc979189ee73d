#include "src/datasets/priors.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/log.h"
#include "src/core/npy.h"
#include "src/core/npz.h"
#include "src/core/strings.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// DynamicNeRF's forward-backward check (its compute_fwdbwd_mask): the flow
// there and back must cancel within half their lengths plus half a pixel.
constexpr float kFbRelative = 0.5f;
constexpr float kFbAbsolute = 0.5f;
// Files named in an error about files that name no frame.
constexpr int kNamesShown = 3;

// A layout pano4d knows: where it lives, what its files are called.
struct KnownLayout {
  PriorKind kind;
  const char* name;
  const char* holds;
  // The folder under the priors root ("" for files in the root itself), or
  // a suffix that folder names end with ("*_depth").
  const char* folder;
  const char* extension;  // of its files
  DepthMeaning meaning = DepthMeaning::kDisparity;
};

// Of each kind, the preferred layout first: metric depth needs no affine;
// flow with the tool's own occlusion masks before flow without.
const KnownLayout kLayouts[] = {
    {PriorKind::kDepth, "MoSca <name>_depth/<frame>.npz",
     "metric depth (key dep, 0 = none)", "*_depth", ".npz",
     DepthMeaning::kMetricDepth},
    {PriorKind::kDepth, "Shape of Motion aligned_depth_anything/<frame>.npy",
     "disparity (Depth Anything aligned to metric depth)",
     "aligned_depth_anything", ".npy"},
    {PriorKind::kDepth, "Shape of Motion unidepth_disp/<frame>.npy",
     "disparity (UniDepth)", "unidepth_disp", ".npy"},
    {PriorKind::kDepth, "Shape of Motion depth_anything/<frame>.png",
     "disparity normalised to uint16 (Depth Anything)", "depth_anything",
     ".png"},
    {PriorKind::kDepth, "DynamicNeRF disp/<frame>.npy",
     "disparity with an unknown affine per frame (MiDaS)", "disp", ".npy"},
    {PriorKind::kFlow, "DynamicNeRF flow/<i>_fwd.npz, <i>_bwd.npz",
     "flow to the next and the previous frame, with masks", "flow", ".npz"},
    {PriorKind::kFlow, "MoSca flow_raft/<a>_to_<b>.npz",
     "flow with masks (float16)", "flow_raft", ".npz"},
    {PriorKind::kFlow, "OmniMotion raft_exhaustive/<a>_<b>.npy",
     "flow between frames a and b (file names with extension)",
     "raft_exhaustive", ".npy"},
    {PriorKind::kTracks, "MoSca *_tap.npz",
     "tracks (T, N, 2) in pixels and visibility (T, N)", "", "_tap.npz"},
    {PriorKind::kTracks, "Shape of Motion bootstapir/<q>_<t>.npy",
     "tracks of frame q's queries at frame t: (N, 4) x, y, occlusion and "
     "distance logits",
     "bootstapir", ".npy"},
    {PriorKind::kTracks, "CoTracker *.npz with tracks and visibility",
     "tracks (T, N, 2) or (1, T, N, 2) and visibility (T, N)", "", ".npz"},
    {PriorKind::kMasks, "DynamicNeRF motion_masks/<frame>.png", "255 = moving",
     "motion_masks", ".png"},
    {PriorKind::kMasks, "Shape of Motion masks/<frame>.png", "foreground > 0",
     "masks", ".png"},
    {PriorKind::kMasks, "MoSca vos_deva/Annotations/<frame>.png",
     "instance colours, black = background", "vos_deva/Annotations", ".png"},
};

std::vector<fs::path> FilesIn(const fs::path& dir, const std::string& ext) {
  std::vector<fs::path> files;
  if (!fs::is_directory(dir)) return files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && name.size() > ext.size() &&
        name.ends_with(ext) && name[0] != '.')
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) {
              return NaturalLess(a.filename().string(), b.filename().string());
            });
  return files;
}

// A root .npz that holds tracks and their visibility (CoTracker's arrays,
// saved by the user), under either of CoTracker's names.
bool HoldsTracks(const fs::path& file) {
  try {
    const NpzArrays arrays = ReadNpz(file);
    return (arrays.count("tracks") && arrays.count("visibility")) ||
           (arrays.count("pred_tracks") && arrays.count("pred_visibility"));
  } catch (const Error&) {
    return false;
  }
}

std::string FileName(const fs::path& p) { return p.filename().string(); }

// The frame each prior file name (without its extension) stands for.
class FrameKeys {
 public:
  explicit FrameKeys(const std::vector<PriorFrame>& frames) : frames_(frames) {
    for (std::size_t i = 0; i < frames.size(); ++i) {
      for (const std::string& key :
           {frames[i].image.filename().string(),
            frames[i].image.stem().string(), frames[i].name}) {
        if (!key.empty()) index_.emplace(key, static_cast<int>(i));
      }
    }
  }
  // -1 when `key` names no frame. A key with an image extension also
  // names the frame of its stem: priors computed on 00000.jpg belong to
  // the frame pano4d wrote as 00000.png.
  int Find(const std::string& key) const {
    auto it = index_.find(key);
    if (it == index_.end()) {
      const fs::path p(key);
      std::string ext = p.extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg")
        it = index_.find(p.stem().string());
    }
    return it == index_.end() ? -1 : it->second;
  }
  // "000.png, 001.png, 002.png, ..." for errors.
  std::string Examples() const {
    std::string text;
    for (std::size_t i = 0; i < frames_.size() && i < kNamesShown; ++i)
      text += (i ? ", " : "") + frames_[i].image.stem().string();
    if (frames_.size() > kNamesShown) text += ", ...";
    return text;
  }

 private:
  const std::vector<PriorFrame>& frames_;
  std::map<std::string, int> index_;
};

// The error for a layout whose file names no frame of the video.
[[noreturn]] void NoSuchFrame(const fs::path& file, const std::string& key,
                              const FrameKeys& keys) {
  throw Error(file.string(), "frame", key,
              "names no frame of this video (its frames are named like " +
                  keys.Examples() + ")");
}

void CheckFinite(const cv::Mat& values, const fs::path& file) {
  if (cv::checkRange(values, true, nullptr, -1e30, 1e30)) return;
  throw Error(file.string(), "values", "NaN or Inf",
              "the prior holds non-finite values; recompute it");
}

// Refuses a map whose aspect ratio is not the frame's.
void CheckAspect(int w, int h, const PriorFrame& frame, const fs::path& file) {
  const double a = static_cast<double>(w) / h;
  const double b = static_cast<double>(frame.width) / frame.height;
  if (w > 0 && h > 0 && std::abs(a / b - 1.0) <= kMaxAspectDifference) return;
  throw Error(file.string(), "size", SizeText(w, h),
              "another aspect ratio than its frame " + frame.name + " (" +
                  SizeText(frame.width, frame.height) +
                  "): a prior of other frames, or cropped");
}

// `map` at the frame's size; nearest, as interpolating across a depth or
// motion edge invents values that neither side has.
cv::Mat ToFrameSize(const cv::Mat& map, const PriorFrame& frame) {
  if (map.cols == frame.width && map.rows == frame.height) return map;
  cv::Mat out;
  cv::resize(map, out, cv::Size(frame.width, frame.height), 0, 0,
             cv::INTER_NEAREST);
  return out;
}

// An .npy or .npz array of (H, W), (H, W, 1) or (1, H, W) as CV_32FC1, or
// (H, W, 2) as CV_32FC2 when `channels` is 2.
cv::Mat MatFromNpy(const NpyArray& a, int channels, const fs::path& file) {
  std::vector<std::int64_t> shape = a.shape;
  if (channels == 1 && shape.size() == 3 && shape[2] == 1) shape.pop_back();
  if (channels == 1 && shape.size() == 3 && shape[0] == 1)
    shape.erase(shape.begin());
  const bool ok = channels == 1 ? shape.size() == 2
                                : shape.size() == 3 && shape[2] == channels;
  if (!ok || shape[0] <= 0 || shape[1] <= 0) {
    std::string text = "(";
    for (std::size_t i = 0; i < a.shape.size(); ++i)
      text += (i ? ", " : "") + std::to_string(a.shape[i]);
    throw Error(file.string(), "shape", text + ")",
                channels == 1 ? "expected (H, W)" : "expected (H, W, 2)");
  }
  const std::vector<float> values = a.ToFloats();
  cv::Mat mat(static_cast<int>(shape[0]), static_cast<int>(shape[1]),
              CV_32FC(channels));
  std::copy(values.begin(), values.end(), mat.ptr<float>());
  CheckFinite(mat, file);
  return mat;
}

// A per-frame layout's files, each with the frame it names.
std::vector<std::pair<int, fs::path>> PerFrameFiles(const PriorLayout& layout,
                                                    const std::string& ext,
                                                    const FrameKeys& keys) {
  std::vector<std::pair<int, fs::path>> out;
  for (const fs::path& file : FilesIn(layout.path, ext)) {
    const std::string name = FileName(file);
    const std::string key = name.substr(0, name.size() - ext.size());
    const int i = keys.Find(key);
    if (i < 0) NoSuchFrame(file, key, keys);
    out.emplace_back(i, file);
  }
  return out;
}

cv::Mat ReadDepthFile(const PriorLayout& layout, const fs::path& file) {
  if (file.extension() == ".npz")
    return MatFromNpy(NpzArray(ReadNpz(file), "dep", file.string()), 1, file);
  if (file.extension() == ".npy") return MatFromNpy(ReadNpy(file), 1, file);
  // Shape of Motion's depth_anything/: disparity scaled to uint16.
  const cv::Mat png = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (png.empty() || png.channels() != 1) {
    throw Error(file.string(), "", "",
                "not a single-channel PNG (" + layout.name + ")");
  }
  cv::Mat out;
  png.convertTo(out, CV_32F);
  return out;
}

// DynamicNeRF's forward-backward mask of `fwd` (a -> b) against `bwd`
// (b -> a), both at one size.
cv::Mat ForwardBackwardMask(const cv::Mat& fwd, const cv::Mat& bwd) {
  cv::Mat map(fwd.size(), CV_32FC2);
  for (int y = 0; y < fwd.rows; ++y)
    for (int x = 0; x < fwd.cols; ++x) {
      const cv::Vec2f f = fwd.at<cv::Vec2f>(y, x);
      map.at<cv::Vec2f>(y, x) = cv::Vec2f(x + f[0], y + f[1]);
    }
  cv::Mat back;
  cv::remap(bwd, back, map, cv::noArray(), cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar(1e6f, 1e6f));
  cv::Mat mask(fwd.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < fwd.rows; ++y)
    for (int x = 0; x < fwd.cols; ++x) {
      const cv::Vec2f f = fwd.at<cv::Vec2f>(y, x);
      const cv::Vec2f b = back.at<cv::Vec2f>(y, x);
      const float error = static_cast<float>(cv::norm(f + b));
      if (error < kFbRelative * (cv::norm(f) + cv::norm(b)) + kFbAbsolute)
        mask.at<std::uint8_t>(y, x) = kMaskOn;
    }
  return mask;
}

// A flow file as read: a -> b at its own resolution, with its mask if any.
struct RawFlow {
  int from = 0, to = 0;
  fs::path file;
  cv::Mat flow, mask;
};

RawFlow ReadFlowFile(const PriorLayout& layout, const fs::path& file, int from,
                     int to) {
  RawFlow raw{from, to, file, {}, {}};
  if (file.extension() == ".npy") {
    raw.flow = MatFromNpy(ReadNpy(file), 2, file);
    // OmniMotion's filter_raft.py: raft_masks/<a>_<b>.png beside the flow,
    // red 255 where the flow is cycle-consistent.
    const fs::path mask = layout.path.parent_path() / "raft_masks" /
                          (file.stem().string() + ".png");
    if (fs::exists(mask)) {
      const cv::Mat image = cv::imread(mask.string(), cv::IMREAD_COLOR);
      if (image.size() != raw.flow.size()) {
        throw Error(mask.string(), "size", SizeText(image.cols, image.rows),
                    "differs from its flow's " +
                        SizeText(raw.flow.cols, raw.flow.rows));
      }
      cv::Mat red;
      cv::extractChannel(image, red, 2);
      raw.mask = red > 0;
    }
    return raw;
  }
  const NpzArrays arrays = ReadNpz(file);
  raw.flow = MatFromNpy(NpzArray(arrays, "flow", file.string()), 2, file);
  (void)layout;
  if (arrays.count("mask")) {
    const cv::Mat m = MatFromNpy(arrays.at("mask"), 1, file);
    if (m.size() != raw.flow.size()) {
      throw Error(file.string(), "mask", SizeText(m.cols, m.rows),
                  "differs from the flow's size " +
                      SizeText(raw.flow.cols, raw.flow.rows));
    }
    raw.mask = m > 0.5f;
  }
  return raw;
}

// The flow files of `layout`, each with the frames it joins.
std::vector<RawFlow> FlowFiles(const PriorLayout& layout, const FrameKeys& keys,
                               int num_frames) {
  std::vector<RawFlow> files;
  if (layout.name.starts_with("DynamicNeRF")) {
    for (const fs::path& file : FilesIn(layout.path, ".npz")) {
      const std::string name = file.stem().string();
      const bool fwd = name.ends_with("_fwd");
      if (!fwd && !name.ends_with("_bwd")) continue;
      const std::string key = name.substr(0, name.size() - 4);
      int from = keys.Find(key);
      if (from < 0) {
        // DynamicNeRF numbers flow files by the frame's index.
        char* end = nullptr;
        const long index = std::strtol(key.c_str(), &end, 10);
        if (!key.empty() && *end == '\0' && index >= 0 && index < num_frames)
          from = static_cast<int>(index);
      }
      if (from < 0) NoSuchFrame(file, key, keys);
      const int to = from + (fwd ? 1 : -1);
      if (to < 0 || to >= num_frames) {
        throw Error(file.string(), "frame", std::to_string(to),
                    std::string("the ") + (fwd ? "next" : "previous") +
                        " frame of " + key + " is not in the video");
      }
      files.push_back({from, to, file, {}, {}});
    }
    return files;
  }
  const bool mosca = layout.name.starts_with("MoSca");
  const std::string ext = mosca ? ".npz" : ".npy";
  for (const fs::path& file : FilesIn(layout.path, ext)) {
    const std::string name = FileName(file);
    const std::string stem = name.substr(0, name.size() - ext.size());
    const std::string separator = mosca ? "_to_" : "_";
    int from = -1, to = -1;
    // Frame names may hold the separator: try every split.
    for (std::size_t pos = stem.find(separator); pos != std::string::npos;
         pos = stem.find(separator, pos + 1)) {
      const int a = keys.Find(stem.substr(0, pos));
      const int b = keys.Find(stem.substr(pos + separator.size()));
      if (a >= 0 && b >= 0) {
        from = a;
        to = b;
        break;
      }
    }
    if (from < 0) {
      throw Error(file.string(), "frames", stem,
                  "does not name two frames of this video as <a>" + separator +
                      "<b> (its frames are named like " + keys.Examples() +
                      ")");
    }
    files.push_back({from, to, file, {}, {}});
  }
  return files;
}

}  // namespace

const char* PriorKindName(PriorKind kind) {
  switch (kind) {
    case PriorKind::kDepth:
      return "depth";
    case PriorKind::kFlow:
      return "flow";
    case PriorKind::kTracks:
      return "tracks";
    case PriorKind::kMasks:
      return "masks";
  }
  return "?";
}

std::vector<const PriorLayout*> PriorsFolder::Of(PriorKind kind) const {
  std::vector<const PriorLayout*> out;
  for (const PriorLayout& l : layouts)
    if (l.kind == kind) out.push_back(&l);
  return out;
}

nlohmann::json PriorsFolder::ToJson() const {
  nlohmann::json list = nlohmann::json::array();
  for (const PriorLayout& l : layouts) {
    list.push_back({{"kind", PriorKindName(l.kind)},
                    {"layout", l.name},
                    {"holds", l.holds},
                    {"path", l.path.string()},
                    {"files", l.files}});
  }
  return {{"root", root.string()}, {"layouts", list}};
}

std::string KnownPriorLayouts() {
  std::string text;
  for (const KnownLayout& k : kLayouts)
    text += std::string(PriorKindName(k.kind)) + ": " + k.name + "\n";
  return text;
}

PriorsFolder ScanPriors(const fs::path& dir) {
  if (!fs::is_directory(dir)) {
    throw Error::In(dir.string(),
                    "is not a folder of priors (--priors): it does not exist "
                    "or is a file");
  }
  PriorsFolder folder;
  folder.root = dir;
  for (const KnownLayout& k : kLayouts) {
    std::vector<std::pair<fs::path, int>> found;  // path, files
    const std::string where = k.folder;
    if (where.empty()) {
      for (const fs::path& file : FilesIn(dir, k.extension)) {
        const bool mosca = std::string(k.extension) == "_tap.npz";
        if (!mosca &&
            (FileName(file).ends_with("_tap.npz") || !HoldsTracks(file)))
          continue;
        found.emplace_back(file, 1);
      }
    } else if (where.starts_with("*")) {
      for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
        const std::string name = FileName(e.path());
        if (e.is_directory() && name.ends_with(where.substr(1)) &&
            name.size() > where.size() - 1) {
          const int n = static_cast<int>(FilesIn(e.path(), k.extension).size());
          if (n > 0) found.emplace_back(e.path(), n);
        }
      }
    } else {
      const int n = static_cast<int>(FilesIn(dir / where, k.extension).size());
      if (n > 0) found.emplace_back(dir / where, n);
    }
    for (const auto& [path, files] : found) {
      PriorLayout l;
      l.kind = k.kind;
      l.name = k.name;
      l.holds = k.holds;
      l.path = path;
      l.files = files;
      l.meaning = k.meaning;
      folder.layouts.push_back(l);
    }
  }
  if (folder.layouts.empty()) {
    std::string found;
    int shown = 0;
    for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
      if (shown++ == 8) {
        found += ", ...";
        break;
      }
      found += (found.empty() ? "" : ", ") + FileName(e.path()) +
               (e.is_directory() ? "/" : "");
    }
    throw Error(dir.string(), "layout", found.empty() ? "empty" : found,
                "holds no prior in a layout pano4d reads; known layouts:\n" +
                    KnownPriorLayouts());
  }
  return folder;
}

std::optional<DepthPrior> ReadDepthPrior(
    const PriorsFolder& folder, const std::vector<PriorFrame>& frames) {
  const std::vector<const PriorLayout*> layouts = folder.Of(PriorKind::kDepth);
  if (layouts.empty()) return std::nullopt;
  const PriorLayout& layout = *layouts.front();
  const FrameKeys keys(frames);
  DepthPrior prior;
  prior.layout = &layout;
  prior.maps.resize(frames.size());
  const std::string ext = layout.path.filename() == "depth_anything" ? ".png"
                          : layout.meaning == DepthMeaning::kMetricDepth
                              ? ".npz"
                              : ".npy";
  for (const auto& [i, file] : PerFrameFiles(layout, ext, keys)) {
    if (!frames[i].used) continue;
    cv::Mat map = ReadDepthFile(layout, file);
    CheckFinite(map, file);
    // Disparity of 0 or below is none (Shape of Motion's aligned maps mark
    // invalid pixels 0); metric depth keeps its 0 = none.
    if (layout.meaning == DepthMeaning::kDisparity)
      map.setTo(std::numeric_limits<float>::quiet_NaN(), map <= 0.0f);
    CheckAspect(map.cols, map.rows, frames[i], file);
    prior.source_width = map.cols;
    prior.source_height = map.rows;
    prior.maps[i] = ToFrameSize(map, frames[i]);
  }
  return prior;
}

std::optional<FlowPrior> ReadFlowPrior(const PriorsFolder& folder,
                                       const std::vector<PriorFrame>& frames,
                                       int max_gap) {
  const std::vector<const PriorLayout*> layouts = folder.Of(PriorKind::kFlow);
  if (layouts.empty()) return std::nullopt;
  const PriorLayout& layout = *layouts.front();
  const FrameKeys keys(frames);
  FlowPrior prior;
  prior.layout = &layout;
  std::vector<RawFlow> raw =
      FlowFiles(layout, keys, static_cast<int>(frames.size()));
  // Read what the run uses: both ends used and within the gap.
  std::map<std::pair<int, int>, std::size_t> by_pair;
  for (std::size_t r = 0; r < raw.size(); ++r) {
    RawFlow& f = raw[r];
    if (!frames[f.from].used || !frames[f.to].used ||
        std::abs(f.to - f.from) > max_gap || f.from == f.to)
      continue;
    RawFlow read = ReadFlowFile(layout, f.file, f.from, f.to);
    CheckAspect(read.flow.cols, read.flow.rows, frames[f.from], f.file);
    f = std::move(read);
    by_pair[{f.from, f.to}] = r;
  }
  for (const auto& [pair, r] : by_pair) {
    const RawFlow& f = raw[r];
    const PriorFrame& frame = frames[f.from];
    FlowField field;
    field.from = f.from;
    field.to = f.to;
    cv::Mat mask = f.mask;
    field.mask_source = "file";
    if (mask.empty()) {
      const auto back = by_pair.find({f.to, f.from});
      if (back != by_pair.end() &&
          raw[back->second].flow.size() == f.flow.size()) {
        mask = ForwardBackwardMask(f.flow, raw[back->second].flow);
        field.mask_source = "forward-backward";
      } else {
        mask = cv::Mat(f.flow.size(), CV_8UC1, cv::Scalar(kMaskOn));
        field.mask_source = "none";
      }
    }
    field.flow = ToFrameSize(f.flow, frame);
    const float sx = static_cast<float>(frame.width) / f.flow.cols;
    const float sy = static_cast<float>(frame.height) / f.flow.rows;
    field.flow.forEach<cv::Vec2f>([&](cv::Vec2f& v, const int*) {
      v[0] *= sx;
      v[1] *= sy;
    });
    field.valid = ToFrameSize(mask, frame);
    prior.source_width = f.flow.cols;
    prior.source_height = f.flow.rows;
    prior.fields.push_back(std::move(field));
  }
  return prior;
}

namespace {

// Appends tracks to a TrackPrior: positions per frame in the tracker's
// pixels, scaled to each frame's (the tracker's size: the other priors',
// else the frame's own).
class TrackAppender {
 public:
  TrackAppender(const std::vector<PriorFrame>& frames, int source_width,
                int source_height, TrackPrior* prior)
      : frames_(frames), w_(source_width), h_(source_height), prior_(prior) {}

  // One track: `at(t, &p)` says whether frame t sees it and where.
  void Add(const std::function<bool(int, Eigen::Vector2f*)>& at) {
    for (int t = 0; t < static_cast<int>(frames_.size()); ++t) {
      Eigen::Vector2f p(0, 0);
      const bool seen = at(t, &p) && frames_[t].used;
      prior_->pixels.push_back(p.cwiseProduct(Scale(t)));
      prior_->visible.push_back(seen ? 1 : 0);
    }
  }

 private:
  Eigen::Vector2f Scale(int i) const {
    const PriorFrame& f = frames_[i];
    const double w = w_ > 0 ? w_ : f.width;
    const double h = h_ > 0 ? h_ : f.height;
    return Eigen::Vector2f(static_cast<float>(f.width / w),
                           static_cast<float>(f.height / h));
  }

  const std::vector<PriorFrame>& frames_;
  int w_, h_;
  TrackPrior* prior_;
};

// Shape of Motion's bootstapir/<q>_<t>.npy: frame q's queries at frame t,
// (N, 4) rows of x, y and the occlusion and distance logits.
void ReadTapirTracks(const PriorLayout& layout,
                     const std::vector<PriorFrame>& frames,
                     TrackAppender* tracks) {
  const int n_frames = static_cast<int>(frames.size());
  const FrameKeys keys(frames);
  std::map<int, std::map<int, fs::path>> by_query;
  for (const fs::path& file : FilesIn(layout.path, ".npy")) {
    const std::string stem = file.stem().string();
    int q = -1, t = -1;
    for (std::size_t pos = stem.find('_'); pos != std::string::npos;
         pos = stem.find('_', pos + 1)) {
      q = keys.Find(stem.substr(0, pos));
      t = keys.Find(stem.substr(pos + 1));
      if (q >= 0 && t >= 0) break;
    }
    if (q < 0 || t < 0) {
      throw Error(file.string(), "frames", stem,
                  "does not name two frames of this video as <q>_<t> (its "
                  "frames are named like " +
                      keys.Examples() + ")");
    }
    by_query[q][t] = file;
  }
  for (const auto& [q, targets] : by_query) {
    std::vector<std::vector<float>> rows(n_frames);  // (N, 4) per frame
    std::int64_t n = -1;
    for (const auto& [t, file] : targets) {
      const NpyArray a = ReadNpy(file);
      if (a.shape.size() != 2 || a.shape[1] != 4 ||
          (n >= 0 && a.shape[0] != n)) {
        throw Error(file.string(), "shape", std::to_string(a.shape.size()),
                    "expected (N, 4) with the same N for every target "
                    "frame of query frame " +
                        frames[q].name);
      }
      n = a.shape[0];
      rows[t] = a.ToFloats();
      const cv::Mat view(static_cast<int>(n), 4, CV_32F, rows[t].data());
      CheckFinite(view, file);
    }
    for (std::int64_t k = 0; k < n; ++k) {
      tracks->Add([&](int t, Eigen::Vector2f* p) {
        if (rows[t].empty()) return false;
        const float* r = &rows[t][k * 4];
        *p = Eigen::Vector2f(r[0], r[1]);
        // Shape of Motion's parse_tapir_track_info: visible where both
        // the occlusion and the distance logits say so.
        const float occluded = 1.0f / (1.0f + std::exp(-r[2]));
        const float far = 1.0f / (1.0f + std::exp(-r[3]));
        return (1.0f - occluded) * (1.0f - far) > 0.5f;
      });
    }
  }
}

// MoSca's *_tap.npz and CoTracker's arrays: (T, N, 2) and (T, N).
void ReadTrackArrays(const fs::path& file, int n_frames,
                     TrackAppender* appender) {
  const NpzArrays arrays = ReadNpz(file);
  const bool cotracker = !arrays.count("tracks");
  const NpyArray& tracks =
      NpzArray(arrays, cotracker ? "pred_tracks" : "tracks", file.string());
  const NpyArray& visibility = NpzArray(
      arrays, cotracker ? "pred_visibility" : "visibility", file.string());
  std::vector<std::int64_t> ts = tracks.shape, vs = visibility.shape;
  if (ts.size() == 4 && ts[0] == 1) ts.erase(ts.begin());
  if (vs.size() == 3 && vs[0] == 1) vs.erase(vs.begin());
  if (vs.size() == 3 && vs[2] == 1) vs.pop_back();
  // SpaTracker's (T, N, 3) carries a depth after x, y.
  if (ts.size() != 3 || (ts[2] != 2 && ts[2] != 3) || vs.size() != 2 ||
      vs[0] != ts[0] || vs[1] != ts[1]) {
    throw Error(file.string(), "shape", "",
                "expected tracks (T, N, 2) and visibility (T, N)");
  }
  const std::int64_t stride = ts[2];
  if (ts[0] != n_frames) {
    throw Error(file.string(), "frames", std::to_string(ts[0]),
                "tracks over another number of frames than the video's " +
                    std::to_string(n_frames));
  }
  const std::vector<float> xy = tracks.ToFloats();
  const std::vector<float> vis = visibility.ToFloats();
  const cv::Mat check(1, static_cast<int>(xy.size()), CV_32F,
                      const_cast<float*>(xy.data()));
  CheckFinite(check, file);
  const std::int64_t n = ts[1];
  for (std::int64_t k = 0; k < n; ++k) {
    appender->Add([&](int t, Eigen::Vector2f* p) {
      const std::size_t i = static_cast<std::size_t>(t * n + k);
      *p = Eigen::Vector2f(xy[i * stride], xy[i * stride + 1]);
      return vis[i] > 0.5f;
    });
  }
}

}  // namespace

std::optional<TrackPrior> ReadTrackPrior(const PriorsFolder& folder,
                                         const std::vector<PriorFrame>& frames,
                                         int source_width, int source_height) {
  const std::vector<const PriorLayout*> layouts = folder.Of(PriorKind::kTracks);
  if (layouts.empty()) return std::nullopt;
  const PriorLayout& layout = *layouts.front();
  TrackPrior prior;
  prior.layout = &layout;
  prior.num_frames = static_cast<int>(frames.size());
  TrackAppender appender(frames, source_width, source_height, &prior);
  if (layout.name.starts_with("Shape of Motion"))
    ReadTapirTracks(layout, frames, &appender);
  else
    ReadTrackArrays(layout.path, prior.num_frames, &appender);
  return prior;
}

std::optional<MaskPrior> ReadMaskPrior(const PriorsFolder& folder,
                                       const std::vector<PriorFrame>& frames) {
  const std::vector<const PriorLayout*> layouts = folder.Of(PriorKind::kMasks);
  if (layouts.empty()) return std::nullopt;
  const PriorLayout& layout = *layouts.front();
  const FrameKeys keys(frames);
  MaskPrior prior;
  prior.layout = &layout;
  prior.masks.resize(frames.size());
  for (const auto& [i, file] : PerFrameFiles(layout, ".png", keys)) {
    if (!frames[i].used) continue;
    const cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) throw Error::In(file.string(), "not a readable PNG");
    CheckAspect(image.cols, image.rows, frames[i], file);
    std::vector<cv::Mat> channels;
    cv::split(image, channels);
    if (channels.size() == 4) channels.pop_back();  // alpha
    // DynamicNeRF's 255 and Shape of Motion's foreground alike: nonzero in
    // any channel (an instance colour) is the object.
    cv::Mat moving(image.size(), CV_8UC1, cv::Scalar(0));
    for (const cv::Mat& c : channels) moving.setTo(kMaskOn, c > 0);
    prior.masks[i] = ToFrameSize(moving, frames[i]);
  }
  return prior;
}

std::vector<std::string> FramesWithout(const std::vector<cv::Mat>& maps,
                                       const std::vector<PriorFrame>& frames) {
  std::vector<std::string> missing;
  for (std::size_t i = 0; i < frames.size() && i < maps.size(); ++i)
    if (frames[i].used && maps[i].empty()) missing.push_back(frames[i].name);
  return missing;
}

}  // namespace pano4d
