#include "colmap_ext/sfm.h"

#include <algorithm>
#include <fstream>
#include <functional>
#include <map>
#include <set>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "colmap_ext/colmap_commands.h"
#include "colmap_ext/colmap_runner.h"
#include "colmap_ext/database.h"
#include "colmap_ext/masks.h"
#include "colmap_ext/model.h"
#include "colmap_ext/register_left_out.h"
#include "colmap_ext/rotation_only_model.h"
#include "colmap_ext/sfm_diagnosis.h"
#include "src/core/camera.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/option_checks.h"
#include "src/core/progress.h"
#include "src/core/stamp.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/core/video.h"
#include "src/core/workspace.h"
#include "src/geometry/motion_segmentation.h"

#include <cstdio>

namespace pano4d {
namespace fs = std::filesystem;
namespace {

const std::set<std::string> kImageExtensions = {".png", ".jpg", ".jpeg",
                                                ".PNG", ".JPG", ".JPEG"};

std::vector<fs::path> ListImages(const fs::path& dir) {
  if (!fs::is_directory(dir))
    throw Error::In(dir.string(), "not a folder of images");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() &&
        kImageExtensions.count(entry.path().extension().string()))
      files.push_back(entry.path());
  }
  // In the order people number files (frame_2 before frame_10): their
  // time order.
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) {
              return NaturalLess(a.filename().string(), b.filename().string());
            });
  if (files.empty())
    throw Error::In(dir.string(), "holds no .png or .jpg images");
  return files;
}

// The size of a width x height image whose longest side is brought down to
// max_size (0: unchanged).
cv::Size ResizedSize(int width, int height, int max_size) {
  const int longest = std::max(width, height);
  if (max_size <= 0 || longest <= max_size) return {width, height};
  const double s = static_cast<double>(max_size) / longest;
  return {std::max(1, static_cast<int>(std::lround(width * s))),
          std::max(1, static_cast<int>(std::lround(height * s)))};
}

cv::Mat Resized(const cv::Mat& bgr, int max_size) {
  const cv::Size size = ResizedSize(bgr.cols, bgr.rows, max_size);
  if (size == bgr.size()) return bgr;
  cv::Mat out;
  cv::resize(bgr, out, size, 0, 0, cv::INTER_AREA);
  return out;
}

// The indices of `count` frames that --stride and --max-frames keep.
std::vector<std::size_t> KeptIndices(std::size_t count, const SfmOptions& o) {
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < count; i += o.stride) {
    if (o.max_frames > 0 && static_cast<int>(kept.size()) >= o.max_frames)
      break;
    kept.push_back(i);
  }
  return kept;
}

// The known frames that --stride and --max-frames keep, with their cameras
// scaled as the frames are by --max-size.
std::vector<KnownFrame> KeptKnownFrames(const SfmOptions& o) {
  std::vector<KnownFrame> kept;
  for (const std::size_t i : KeptIndices(o.known.size(), o)) {
    KnownFrame frame = o.known[i];
    const Camera& c = frame.camera.camera;
    const cv::Size size = ResizedSize(c.width, c.height, o.max_size);
    frame.camera.camera = c.Rescaled(size.width, size.height);
    kept.push_back(std::move(frame));
  }
  return kept;
}

// The known cameras as a COLMAP model without points, for
// point_triangulator, with the image and camera ids that feature_extractor
// gave each image in `database`. Throws pano4d::Error for a frame the
// database lacks.
ColmapModel KnownModel(const std::vector<KnownFrame>& frames,
                       const fs::path& database) {
  std::map<std::string, DatabaseImage> by_name;
  for (const DatabaseImage& image : ReadDatabaseImages(database))
    by_name[image.name] = image;
  ColmapModel model;
  std::set<std::uint32_t> cameras;
  for (const KnownFrame& frame : frames) {
    const auto found = by_name.find(frame.name);
    if (found == by_name.end()) {
      throw Error(database.string(), "images", frame.name,
                  "frame missing from the database; rerun with --force");
    }
    const DatabaseImage& row = found->second;
    if (cameras.insert(row.camera_id).second)
      model.cameras.push_back(FromCamera(row.camera_id, frame.camera.camera));
    ColmapImage image;
    image.image_id = row.image_id;
    image.camera_id = row.camera_id;
    image.name = frame.name;
    image.SetCamFromWorld(frame.camera.cam_from_world);
    model.images.push_back(std::move(image));
  }
  model.BuildIndex();
  return model;
}

bool SameCamera(const std::vector<KnownFrame>& frames) {
  for (const KnownFrame& f : frames) {
    const Camera& a = f.camera.camera;
    const Camera& b = frames.front().camera.camera;
    if (a.model_id != b.model_id || a.width != b.width ||
        a.height != b.height || a.params != b.params)
      return false;
  }
  return true;
}

// A video's frames, every --stride-th up to --max-frames, named after
// their index in the video.
std::vector<std::string> WriteVideoFrames(const SfmOptions& o,
                                          const fs::path& images_dir) {
  std::vector<std::string> names;
  VideoReader reader(o.video, {.stride = o.stride, .max_frames = o.max_frames});
  ProgressBar bar("sfm: frames", reader.info().frame_count / o.stride);
  Image frame;
  std::int64_t index = 0;
  while (reader.Next(&frame, &index)) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%06lld.png",
                  static_cast<long long>(index));
    WritePng8(images_dir / name, Resized(frame.ToBgr8(), o.max_size));
    names.push_back(name);
    bar.Add();
  }
  return names;
}

// The known frames (a dataset's), each checked against its camera's size.
std::vector<std::string> WriteKnownFrames(const SfmOptions& o,
                                          const fs::path& images_dir) {
  std::vector<std::string> names;
  const std::vector<std::size_t> kept = KeptIndices(o.known.size(), o);
  ProgressBar bar("sfm: frames", kept.size());
  for (const std::size_t i : kept) {
    const cv::Mat bgr = ReadImage(o.known[i].image).ToBgr8();
    const Camera& camera = o.known[i].camera.camera;
    if (bgr.cols != camera.width || bgr.rows != camera.height) {
      throw Error(
          o.known[i].image.string(), "size", SizeText(bgr.cols, bgr.rows),
          "differs from its camera's " + SizeText(camera.width, camera.height));
    }
    WritePng8(images_dir / o.known[i].name, Resized(bgr, o.max_size));
    names.push_back(o.known[i].name);
    bar.Add();
  }
  return names;
}

// A folder's images in number order. COLMAP and pano4d's later stages
// order frames by name as bytes: names that do not sort in time order
// (frame_2, frame_10) get their position in front (000001_frame_2).
std::vector<std::string> WriteFolderFrames(const SfmOptions& o,
                                           const fs::path& images_dir) {
  const std::vector<fs::path> files = ListImages(o.images);
  std::vector<fs::path> kept;
  for (const std::size_t i : KeptIndices(files.size(), o))
    kept.push_back(files[i]);
  std::vector<std::string> stems;
  for (const fs::path& f : kept) stems.push_back(f.stem().string());
  const bool prefix = !std::is_sorted(stems.begin(), stems.end());
  if (prefix) {
    PANO4D_LOG(kInfo) << "sfm: the frames' names do not sort in their "
                         "number order; numbered 000000_"
                      << stems.front() << ".png on";
  }
  std::vector<std::string> names;
  ProgressBar bar("sfm: frames", kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Image image = ReadImage(kept[i]);
    const std::string name =
        (prefix ? ZeroPadded(static_cast<std::int64_t>(i), 6) + "_" : "") +
        stems[i] + ".png";
    WritePng8(images_dir / name, Resized(image.ToBgr8(), o.max_size));
    names.push_back(name);
    bar.Add();
  }
  return names;
}

// Frames into WS/images as PNG (lossless, and COLMAP reads them), named
// after the video frame index or kept from the source folder.
std::vector<std::string> WriteFrames(const SfmOptions& o,
                                     const fs::path& images_dir) {
  std::error_code error;
  if (!o.images.empty() && fs::equivalent(o.images, images_dir, error)) {
    // An existing COLMAP workspace: its images are the frames, as they are.
    if (o.stride != 1 || o.max_frames != 0 || o.max_size != 0) {
      throw Error("sfm", "--images", o.images.string(),
                  "is the workspace's own images folder, which "
                  "--stride/--max-frames/--max-size would overwrite; give "
                  "another folder");
    }
    std::vector<std::string> names;
    for (const fs::path& f : ListImages(images_dir))
      names.push_back(f.filename().string());
    return names;
  }
  fs::remove_all(images_dir);
  EnsureDirectory(images_dir);
  const std::vector<std::string> names =
      !o.video.empty()   ? WriteVideoFrames(o, images_dir)
      : !o.known.empty() ? WriteKnownFrames(o, images_dir)
                         : WriteFolderFrames(o, images_dir);
  if (names.size() < 2) {
    throw Error::In(!o.video.empty()    ? o.video.string()
                    : !o.images.empty() ? o.images.string()
                                        : std::string("known frames"),
                    "gave " + std::to_string(names.size()) +
                        " frame(s); SfM needs at least 2 (a longer "
                        "capture, or with `pano4d sfm` a lower --stride)");
  }
  return names;
}

// The folders of WS/sparse that hold a complete model.
std::vector<fs::path> ModelFolders(const fs::path& sparse) {
  std::vector<fs::path> folders;
  if (!fs::is_directory(sparse)) return folders;
  for (const auto& entry : fs::directory_iterator(sparse)) {
    if (entry.is_directory() && DetectModelFormat(entry.path()))
      folders.push_back(entry.path());
  }
  return folders;
}

// Moves the model with the most registered images to WS/sparse/0 (the
// mapper numbers models in the order it found them) and returns that
// count; 0 when the mapper produced no model.
int SelectLargestModel(const fs::path& sparse) {
  std::vector<std::pair<std::size_t, fs::path>> found;
  for (const fs::path& folder : ModelFolders(sparse))
    found.emplace_back(ReadModel(folder).images.size(), folder);
  if (found.empty()) return 0;
  const auto largest = std::max_element(
      found.begin(), found.end(),
      [](const auto& a, const auto& b) { return a.first < b.first; });
  if (largest->second.filename() != "0") {
    const fs::path zero = sparse / "0", swap = sparse / "0.swap";
    fs::rename(zero, swap);
    fs::rename(largest->second, zero);
    fs::rename(swap, largest->second);
  }
  return static_cast<int>(largest->first);
}

// sequential_matcher pairs each frame with the next ones in COLMAP's order
// (SequentialMatcherOrder); frames out of time order there would be
// matched with the wrong neighbours, and a video's reconstruction falls
// apart. Throws pano4d::Error naming the first frame where the orders part.
void CheckSequentialOrder(const fs::path& database,
                          const std::vector<std::string>& time_order) {
  const std::vector<std::string> colmap_order =
      SequentialMatcherOrder(database);
  std::vector<std::string> ours;
  const std::set<std::string> in_database(colmap_order.begin(),
                                          colmap_order.end());
  for (const std::string& n : time_order)
    if (in_database.count(n)) ours.push_back(n);
  for (std::size_t i = 0; i < ours.size() && i < colmap_order.size(); ++i) {
    if (ours[i] == colmap_order[i]) continue;
    throw Error(database.string(), "images", colmap_order[i],
                "sequential_matcher takes frames in name order, and there "
                "frame " +
                    std::to_string(i) + " is " + colmap_order[i] +
                    " where the video has " + ours[i] +
                    ": rename the frames with zero-padded numbers "
                    "(frame_000002.png), or use --matcher exhaustive");
  }
}

}  // namespace

std::string SfmReport::CameraMotion() const {
  return static_camera   ? "static camera"
         : rotation_only ? "rotation-only"
                         : "general";
}

nlohmann::json SfmOptions::ToJson() const {
  return {{"video", video.string()},
          {"images", images.string()},
          {"known_frames", known.size()},
          {"workspace", workspace.string()},
          {"camera_model", camera_model},
          {"matcher", matcher},
          {"stride", stride},
          {"max_frames", max_frames},
          {"max_size", max_size},
          {"dynamic_masks", dynamic_masks},
          {"single_camera", single_camera},
          {"force", force},
          {"colmap", colmap.string()}};
}

void SfmOptions::Check() const {
  if (!video.empty() + !images.empty() + !known.empty() != 1) {
    throw Error("sfm", "--video/--images/--dataset", "",
                "give exactly one of them");
  }
  for (const KnownFrame& frame : known) {
    frame.camera.camera.Check(frame.image.string());
    if (fs::path(frame.name).extension() != ".png")
      throw Error("sfm", "known frame name", frame.name, "must end in .png");
  }
  if (workspace.empty()) throw Error("sfm", "--workspace", "", "required");
  if (!CameraModelFromName(camera_model)) {
    throw Error("sfm", "--camera-model", camera_model,
                "not a COLMAP camera model (e.g. SIMPLE_RADIAL, OPENCV, "
                "PINHOLE)");
  }
  if (!matcher.empty() && matcher != "sequential" && matcher != "exhaustive")
    throw Error("sfm", "--matcher", matcher,
                "expected sequential or exhaustive");
  if (stride < 1)
    throw Error("sfm", "--stride", std::to_string(stride), "must be >= 1");
  CheckNonNegative(max_frames, "sfm", "--max-frames");
  CheckNonNegative(max_size, "sfm", "--max-size");
}

namespace {

// sfm's steps, in the order RunSfm takes them. Each runs unless its stamp
// (src/core/stamp.h, WS/pano4d/stamps/sfm/<step>.json) says an earlier run
// completed it with the same inputs and its outputs are still there; once
// one step runs, every later one does too.
class SfmSteps {
 public:
  explicit SfmSteps(const SfmOptions& o)
      : o_(o),
        colmap_(o.colmap),
        ws_(o.workspace),
        logs_(ws_.logs()),
        images_(ws_.images()),
        masks_(ws_.colmap_masks()),
        database_(ws_.database()),
        sparse_(ws_.sparse()),
        known_(KeptKnownFrames(o)),
        matcher_(!o.matcher.empty()
                     ? o.matcher
                     : (!o.video.empty() ? "sequential" : "exhaustive")) {
    EnsureDirectory(logs_);
  }

  bool has_known_poses() const { return !known_.empty(); }

  void WriteFramesStep();
  void DynamicMasksStep();
  void FeatureExtractorStep();
  void MatcherStep();
  void PointTriangulatorStep();
  void MapperStep();
  void RegisterLeftOutStep();
  void UndistortStep();
  SfmReport Summarize();

 private:
  void Step(const std::string& name, const StageRecord& record,
            const std::function<void()>& run);
  StageRecord Record() const { return StageRecord(ws_.root()); }
  void AdoptOldStamp(const StageStamp& stamp, const StageRecord& record) const;
  Error NothingPosed(const std::string& colmap_said) const;

  const SfmOptions& o_;
  const ColmapRunner colmap_;
  const Workspace ws_;
  const fs::path logs_, images_, masks_, database_, sparse_;
  const std::vector<KnownFrame> known_;
  const std::string matcher_;
  std::vector<fs::path> frames_;
  std::vector<std::string> frame_names_;  // in time order
  std::map<std::string, double> moving_fraction_;
  bool earlier_step_ran_ = false;
  SfmReport report_;
  nlohmann::json timings_ = nlohmann::json::object();
};

// A workspace from before the stamps moved kept each step's in
// WS/pano4d/logs/<step>.done.json ({"inputs": options with "files",
// "seconds"}): taken over once, so its steps are not run again.
void SfmSteps::AdoptOldStamp(const StageStamp& stamp,
                             const StageRecord& record) const {
  const fs::path old = logs_ / (stamp.stage().substr(4) + ".done.json");
  if (fs::exists(ws_.stamps() / (stamp.stage() + ".json")) || !fs::exists(old))
    return;
  const nlohmann::json was = nlohmann::json::parse(ReadTextFile(old), nullptr,
                                                   /*allow_exceptions=*/false);
  if (!was.is_object() || !was.value("inputs", nlohmann::json()).is_object())
    return;
  nlohmann::json inputs = was["inputs"];
  const nlohmann::json files = inputs.value("files", nlohmann::json::object());
  inputs.erase("files");
  nlohmann::json adopted = record.json();
  adopted["options"] = inputs;
  adopted["files"] = files;
  adopted["seconds"] = was.value("seconds", 0.0);
  WriteFileAtomically(ws_.stamps() / (stamp.stage() + ".json"),
                      adopted.dump(1) + "\n");
  fs::remove(old);
}

void SfmSteps::Step(const std::string& name, const StageRecord& record,
                    const std::function<void()>& run) {
  const StageStamp stamp(ws_, "sfm/" + name);
  AdoptOldStamp(stamp, record);
  const std::optional<std::string> forced =
      o_.force            ? std::optional<std::string>("--force")
      : earlier_step_ran_ ? std::optional<std::string>("an earlier step ran")
                          : std::nullopt;
  const std::optional<std::string> why = stamp.Decide(record, forced);
  const bool runs = why.has_value();
  double seconds = runs ? 0.0 : stamp.Seconds();
  if (runs) {
    Timer timer;
    stamp.Remove();  // a step that fails half way leaves no stamp
    run();
    seconds = timer.WallSeconds();
    stamp.Write(record, seconds);
    earlier_step_ran_ = true;
  }
  report_.steps.push_back({name, seconds, !runs, why.value_or("")});
  timings_[name] = {{"seconds", seconds}, {"skipped", !runs}};
}

void SfmSteps::WriteFramesStep() {
  StageRecord record = Record();
  record
      .Option("video", o_.video.empty() ? "" : fs::absolute(o_.video).string())
      .Option("images",
              o_.images.empty() ? "" : fs::absolute(o_.images).string())
      .Option("stride", o_.stride)
      .Option("max_frames", o_.max_frames)
      .Option("max_size", o_.max_size);
  nlohmann::json known = nlohmann::json::array();
  for (const KnownFrame& f : o_.known)
    known.push_back(fs::absolute(f.image).string());
  record.Option("known", known);
  // What the frames are read from: a frame replaced in the folder makes the
  // step run again.
  if (!o_.video.empty()) record.File(o_.video);
  if (!o_.images.empty()) record.File(o_.images);
  for (const KnownFrame& f : o_.known) record.File(f.image);
  record.Output(images_);
  Step("frames", record, [&] { WriteFrames(o_, images_); });
  frames_ = ListImages(images_);
  report_.frames = static_cast<int>(frames_.size());
  for (const fs::path& f : frames_)
    frame_names_.push_back(f.filename().string());
}

// COLMAP's convention in WS/masks, pano4d's in WS/pano4d/tracks/dynamic;
// then each frame's moving share, from the mask files (this run's or an
// earlier one's).
void SfmSteps::DynamicMasksStep() {
  if (!o_.dynamic_masks) return;
  StageRecord record = Record();
  record.Option("frames", report_.frames).Output(masks_);
  Step("dynamic_masks", record, [&] {
    std::vector<cv::Mat> bgr;
    for (const fs::path& f : frames_) bgr.push_back(ReadImage(f).ToBgr8());
    DynamicMaskStats stats;
    const std::vector<cv::Mat> masks = ComputeDynamicMasks(bgr, {}, &stats);
    fs::remove_all(masks_);
    WriteColmapMasks(masks, frame_names_, masks_);
    WriteDynamicMasks(masks, frame_names_, ws_.dynamic_masks());
    PANO4D_LOG(kInfo) << "sfm: " << stats.BriefReport();
  });
  double sum = 0;
  for (const std::string& name : frame_names_) {
    const cv::Mat mask = ReadMask(MaskPathFor(ws_.dynamic_masks(), name));
    moving_fraction_[name] =
        cv::countNonZero(mask) / static_cast<double>(mask.total());
    sum += moving_fraction_[name];
  }
  report_.mean_dynamic_fraction = sum / frames_.size();
}

// SIFT on the CPU; with known poses, of the known frames only (the database
// maps them by name) with the known camera where it is shared.
void SfmSteps::FeatureExtractorStep() {
  const bool known_shared = !known_.empty() && SameCamera(known_);
  const std::string camera_model =
      known_.empty() ? o_.camera_model
                     : std::string(known_.front().camera.camera.info().name);
  const bool single_camera = known_.empty() ? o_.single_camera : known_shared;
  StageRecord record = Record();
  record.Option("camera_model", camera_model)
      .Option("single_camera", single_camera)
      .Option("masks", o_.dynamic_masks)
      .Option("known", !known_.empty())
      .Output(database_);
  Step("feature_extractor", record, [&] {
    fs::remove(database_);
    FeatureExtractorSettings settings;
    settings.database = database_;
    settings.images = images_;
    settings.camera_model = camera_model;
    settings.single_camera = single_camera;
    if (o_.dynamic_masks) settings.masks = masks_;
    if (!known_.empty()) {
      std::string list;
      for (const KnownFrame& f : known_) list += f.name + "\n";
      WriteFileAtomically(ws_.image_list(), list);
      settings.image_list = ws_.image_list();
      if (known_shared) {
        for (const double p : known_.front().camera.camera.params) {
          char buffer[32];
          std::snprintf(buffer, sizeof(buffer), "%.17g", p);
          if (!settings.camera_params.empty()) settings.camera_params += ',';
          settings.camera_params += buffer;
        }
      }
    }
    colmap_.Run("feature_extractor", FeatureExtractorArgs(settings),
                logs_ / "feature_extractor.log",
                "check that the frames are readable images");
  });
}

void SfmSteps::MatcherStep() {
  if (matcher_ == "sequential") CheckSequentialOrder(database_, frame_names_);
  StageRecord record = Record();
  record.Option("matcher", matcher_).Output(database_);
  Step(matcher_ + "_matcher", record, [&] {
    colmap_.Run(matcher_ + "_matcher", MatcherArgs(database_),
                logs_ / (matcher_ + "_matcher.log"),
                "out of memory on many images: use --matcher sequential");
  });
}

// The poses and intrinsics are given: only points are estimated.
void SfmSteps::PointTriangulatorStep() {
  StageRecord record = Record();
  record.Option("frames", report_.frames).Output(sparse_ / "0");
  Step("point_triangulator", record, [&] {
    const fs::path input = ws_.known_model();
    fs::remove_all(input);
    WriteModel(KnownModel(known_, database_), input, ColmapFormat::kText);
    fs::remove_all(sparse_);
    EnsureDirectory(sparse_ / "0");
    colmap_.Run("point_triangulator",
                PointTriangulatorArgs(database_, images_, input, sparse_ / "0"),
                logs_ / "point_triangulator.log",
                matcher_ == "exhaustive"
                    ? "too few matches between frames with known poses, with "
                      "every pair already matched: frames this small or this "
                      "plain give too few features (a lower --factor keeps "
                      "more pixels)"
                    : "too few matches between frames with known poses: try "
                      "--matcher exhaustive");
  });
}

// Nothing posed: the diagnosis says why, in place of a generic remedy.
Error SfmSteps::NothingPosed(const std::string& colmap_said) const {
  const SfmDiagnosis d =
      DiagnoseSfm(ReadFrameEvidence(database_, {}, moving_fraction_));
  return Error("colmap", "mapper",
               "0 of " + std::to_string(report_.frames) + " frames posed",
               "Cause: " + d.Cause() + ". To try: " + d.Remedy() + " (" +
                   colmap_said + ")");
}

// The largest model becomes WS/sparse/0; a camera that only turns, or
// stands still, gets the rotation-only model instead.
void SfmSteps::MapperStep() {
  StageRecord record = Record();
  record.Option("frames", report_.frames)
      .Option("options", RelaxedMapperArgs())
      .Output(sparse_ / "0");
  Step("mapper", record, [&] {
    fs::remove_all(sparse_);
    EnsureDirectory(sparse_);
    const Image first = ReadImage(frames_.front());
    if (TryRotationOnlyModel(database_, first.width(), first.height(),
                             sparse_ / "0"))
      return;
    try {
      colmap_.Run("mapper", MapperArgs(database_, images_, sparse_),
                  logs_ / "mapper.log");
    } catch (const Error& e) {
      throw NothingPosed(e.problem());
    }
    if (SelectLargestModel(sparse_) == 0) {
      throw NothingPosed("colmap mapper wrote no model; log: " +
                         (logs_ / "mapper.log").string());
    }
  });
}

// Frames the mapper left out, posed by PnP against its points; the log
// file says how many, for a later run that skips the step.
void SfmSteps::RegisterLeftOutStep() {
  const fs::path left_out_json = logs_ / "register_left_out.json";
  StageRecord record = Record();
  record.Option("frames", report_.frames)
      .Output(left_out_json)
      .Output(sparse_ / "0");
  Step("register_left_out", record, [&] {
    ColmapModel model = ReadModel(sparse_ / "0");
    const LeftOutReport left_out = RegisterLeftOutFrames(database_, &model);
    if (!left_out.posed.empty()) {
      // The whole model swapped in at once: a killed run leaves the
      // mapper's model or this one, never a mixture.
      const fs::path next = sparse_ / "0.left_out";
      fs::remove_all(next);
      WriteModel(model, next, ColmapFormat::kBinary);
      fs::remove_all(sparse_ / "0");
      fs::rename(next, sparse_ / "0");
    }
    WriteJson(left_out_json,
              {{"left_out", left_out.left_out}, {"posed", left_out.posed}});
  });
  report_.posed_by_pnp = static_cast<int>(
      GetJson<Json>(ReadJson(left_out_json), "posed", left_out_json.string())
          .size());
}

// Undistortion, so that later stages see pinhole cameras.
void SfmSteps::UndistortStep() {
  report_.models = static_cast<int>(ModelFolders(sparse_).size());
  report_.model = sparse_ / "0";
  report_.images = images_;
  const ColmapModel mapped = ReadModel(report_.model);
  const bool distorted = std::any_of(
      mapped.cameras.begin(), mapped.cameras.end(), [](const ColmapCamera& c) {
        return c.model_id != static_cast<int>(CameraModelId::kSimplePinhole) &&
               c.model_id != static_cast<int>(CameraModelId::kPinhole);
      });
  if (!distorted) return;
  const fs::path out = ws_.undistorted();
  StageRecord record = Record();
  record.Option("model_images", mapped.images.size()).Output(out / "sparse");
  Step("image_undistorter", record, [&] {
    fs::remove_all(out);
    colmap_.Run("image_undistorter",
                ImageUndistorterArgs(images_, report_.model, out),
                logs_ / "image_undistorter.log",
                "check free disk space in the workspace");
  });
  report_.model = out / "sparse";
  report_.images = out / "images";
}

// The model's figures and the diagnosis, into the report and
// WS/pano4d/sfm.json.
SfmReport SfmSteps::Summarize() {
  const ColmapModel model = ReadModel(report_.model);
  report_.rotation_only = IsRotationOnly(model);
  report_.static_camera = IsStaticCamera(model);
  report_.registered = static_cast<int>(model.images.size());
  report_.points3D = static_cast<int>(model.points3D.size());
  double error_sum = 0;
  for (const ColmapPoint3D& p : model.points3D) error_sum += p.error;
  report_.mean_reprojection_error =
      model.points3D.empty() ? 0.0 : error_sum / model.points3D.size();
  std::set<std::string> posed;
  for (const ColmapImage& image : model.images) posed.insert(image.name);
  report_.diagnosis =
      DiagnoseSfm(ReadFrameEvidence(database_, posed, moving_fraction_));
  // Frames the database lacks (never imported) are unposed too.
  report_.diagnosis.frames = std::max(report_.diagnosis.frames, report_.frames);

  const fs::path ws = ws_.root();
  const nlohmann::json summary = {
      {"frames", report_.frames},
      {"registered", report_.registered},
      {"posed_by_pnp", report_.posed_by_pnp},
      {"posed_fraction", report_.diagnosis.PosedFraction()},
      {"camera_motion", report_.CameraMotion()},
      {"diagnosis", report_.diagnosis.ToJson()},
      {"points3D", report_.points3D},
      {"mean_reprojection_error_px", report_.mean_reprojection_error},
      {"models", report_.models},
      {"model", fs::relative(report_.model, ws).string()},
      {"images", fs::relative(report_.images, ws).string()},
      {"camera_model", o_.camera_model},
      {"matcher", matcher_},
      {"dynamic_masks", o_.dynamic_masks},
      {"mean_dynamic_fraction", report_.mean_dynamic_fraction},
      {"options", o_.ToJson()}};
  // Rewritten only when it says something new: the depth stage's stamp
  // records its modification time.
  const std::string text = summary.dump(2) + "\n";
  if (!fs::exists(ws_.sfm_json()) || ReadTextFile(ws_.sfm_json()) != text)
    WriteFileAtomically(ws_.sfm_json(), text);
  WriteFileAtomically(logs_ / "timings.json", timings_.dump(2) + "\n");
  return report_;
}

}  // namespace

SfmReport RunSfm(const SfmOptions& o) {
  o.Check();
  SfmSteps steps(o);
  steps.WriteFramesStep();
  steps.DynamicMasksStep();
  steps.FeatureExtractorStep();
  steps.MatcherStep();
  if (steps.has_known_poses()) {
    steps.PointTriangulatorStep();
  } else {
    steps.MapperStep();
    steps.RegisterLeftOutStep();
  }
  steps.UndistortStep();
  return steps.Summarize();
}

}  // namespace pano4d
