#include "colmap_ext/sfm.h"

#include <algorithm>
#include <fstream>
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

// A step's stamp: the inputs it ran with, written once its outputs are
// complete. A later run skips the step when the stamp says the same inputs
// (and every earlier step was skipped too); --force ignores stamps.
class Stamps {
 public:
  Stamps(fs::path dir, bool force) : dir_(std::move(dir)), force_(force) {}

  // The seconds the step took when it completed with the same inputs, or
  // nullopt when it must run (no stamp, other inputs, an earlier step ran,
  // --force), with the reason in why_run().
  std::optional<double> Done(const std::string& step,
                             const nlohmann::json& inputs) {
    if (force_) return Redo("--force");
    if (redo_) return Redo("an earlier step ran");
    std::ifstream in(dir_ / (step + ".done.json"));
    const nlohmann::json stamp =
        nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (!stamp.is_object() ||
        !stamp.value("seconds", nlohmann::json()).is_number())
      return Redo("it has not completed in this workspace");
    const nlohmann::json stamped = stamp.value("inputs", nlohmann::json());
    if (!stamped.is_object()) return Redo("its stamp is unreadable");
    // As stamp.h compares a stage's inputs: files said by name.
    const auto as_stage = [](nlohmann::json in) {
      nlohmann::json files = in.value("files", nlohmann::json::object());
      in.erase("files");
      return nlohmann::json{{"options", in}, {"files", files}};
    };
    if (const std::optional<std::string> why =
            InputsDifference(as_stage(stamped), as_stage(inputs)))
      return Redo(*why);
    return stamp["seconds"].get<double>();
  }
  const std::string& why_run() const { return why_run_; }
  void Mark(const std::string& step, const nlohmann::json& inputs,
            double seconds) {
    const nlohmann::json stamp = {{"inputs", inputs}, {"seconds", seconds}};
    WriteFileAtomically(dir_ / (step + ".done.json"), stamp.dump(2) + "\n");
    redo_ = true;  // everything after a step that ran runs again
  }
  void Clear(const std::string& step) {
    fs::remove(dir_ / (step + ".done.json"));
  }
  void Invalidate(const std::string& why) {
    redo_ = true;
    why_run_ = why;
  }

 private:
  std::optional<double> Redo(const std::string& why) {
    Invalidate(why);
    return std::nullopt;
  }

  std::string why_run_;
  fs::path dir_;
  bool force_;
  bool redo_ = false;
};

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

// The known frames that --stride and --max-frames keep, with their cameras
// scaled as the frames are by --max-size.
std::vector<KnownFrame> KeptKnownFrames(const SfmOptions& o) {
  std::vector<KnownFrame> kept;
  for (std::size_t i = 0; i < o.known.size(); i += o.stride) {
    if (o.max_frames > 0 && static_cast<int>(kept.size()) >= o.max_frames)
      break;
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
  std::vector<std::string> names;
  if (!o.video.empty()) {
    VideoReader reader(o.video,
                       {.stride = o.stride, .max_frames = o.max_frames});
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
  } else if (!o.known.empty()) {
    ProgressBar bar("sfm: frames", o.known.size());
    for (std::size_t i = 0; i < o.known.size(); i += o.stride) {
      if (o.max_frames > 0 && static_cast<int>(names.size()) >= o.max_frames)
        break;
      const cv::Mat bgr = ReadImage(o.known[i].image).ToBgr8();
      const Camera& camera = o.known[i].camera.camera;
      if (bgr.cols != camera.width || bgr.rows != camera.height) {
        throw Error(o.known[i].image.string(), "size",
                    SizeText(bgr.cols, bgr.rows),
                    "differs from its camera's " +
                        SizeText(camera.width, camera.height));
      }
      WritePng8(images_dir / o.known[i].name, Resized(bgr, o.max_size));
      names.push_back(o.known[i].name);
      bar.Add(o.stride);
    }
  } else {
    std::vector<fs::path> files;
    for (const fs::path& f : ListImages(o.images)) files.push_back(f);
    std::vector<fs::path> kept;
    for (std::size_t i = 0; i < files.size(); i += o.stride) {
      if (o.max_frames > 0 && static_cast<int>(kept.size()) >= o.max_frames)
        break;
      kept.push_back(files[i]);
    }
    // COLMAP and pano4d's later stages order frames by name as bytes:
    // names that do not sort in time order (frame_2, frame_10) get their
    // position in front (000001_frame_2).
    std::vector<std::string> stems;
    for (const fs::path& f : kept) stems.push_back(f.stem().string());
    const bool prefix = !std::is_sorted(stems.begin(), stems.end());
    if (prefix) {
      PANO4D_LOG(kInfo) << "sfm: the frames' names do not sort in their "
                           "number order; numbered 000000_"
                        << stems.front() << ".png on";
    }
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
  }
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
  if (max_frames < 0)
    throw Error("sfm", "--max-frames", std::to_string(max_frames),
                "must be >= 0");
  if (max_size < 0)
    throw Error("sfm", "--max-size", std::to_string(max_size), "must be >= 0");
}

SfmReport RunSfm(const SfmOptions& o) {
  o.Check();
  const ColmapRunner colmap(o.colmap);
  const Workspace workspace(o.workspace);
  const fs::path ws = workspace.root(), logs = workspace.logs();
  const fs::path images_dir = workspace.images();
  const fs::path masks_dir = workspace.colmap_masks();
  const fs::path database = workspace.database(), sparse = workspace.sparse();
  EnsureDirectory(logs);
  Stamps stamps(logs, o.force);
  SfmReport report;
  nlohmann::json timings = nlohmann::json::object();
  // Runs a step unless an earlier run completed it with the same inputs and
  // its outputs are still there.
  const auto step = [&](const std::string& name, const nlohmann::json& inputs,
                        const std::function<bool()>& outputs_exist,
                        const std::function<void()>& run) {
    Timer timer;
    std::optional<double> earlier = stamps.Done(name, inputs);
    if (earlier && !outputs_exist()) {
      stamps.Invalidate("its outputs are gone");
      earlier.reset();
    }
    if (earlier) {
      PANO4D_LOG(kInfo) << "sfm: " << name << ": complete from an earlier run";
    } else {
      PANO4D_LOG(kInfo) << "sfm: " << name << " ... (" << stamps.why_run()
                        << ")";
      stamps.Clear(name);  // a step that fails half way leaves no stamp
      run();
      stamps.Mark(name, inputs, timer.WallSeconds());
    }
    const double seconds = earlier.value_or(timer.WallSeconds());
    report.steps.push_back({name, seconds, earlier.has_value()});
    timings[name] = {{"seconds", seconds}, {"skipped", earlier.has_value()}};
  };
  const auto exists = [](const fs::path& path) {
    return [path] { return fs::exists(path); };
  };

  // 1. Frames.
  const nlohmann::json frame_inputs = {
      {"video", o.video.empty() ? "" : fs::absolute(o.video).string()},
      {"images", o.images.empty() ? "" : fs::absolute(o.images).string()},
      {"stride", o.stride},
      {"max_frames", o.max_frames},
      {"max_size", o.max_size},
      {"known",
       [&] {
         nlohmann::json images = nlohmann::json::array();
         for (const KnownFrame& f : o.known)
           images.push_back(fs::absolute(f.image).string());
         return images;
       }()},
      // What the frames are read from, by size and modification time: a
      // frame replaced in the folder makes the step run again.
      {"files", [&] {
         StageInputs files(ws);
         if (!o.video.empty()) files.File(o.video);
         if (!o.images.empty()) files.File(o.images);
         for (const KnownFrame& f : o.known) files.File(f.image);
         return files.json()["files"];
       }()}};
  step("frames", frame_inputs, exists(images_dir),
       [&] { WriteFrames(o, images_dir); });
  std::vector<fs::path> frames = ListImages(images_dir);
  report.frames = static_cast<int>(frames.size());
  std::vector<std::string> frame_names;  // in time order
  for (const fs::path& f : frames) frame_names.push_back(f.filename().string());

  // 2. Dynamic masks (COLMAP's convention in WS/masks, pano4d's in
  // WS/pano4d/tracks/dynamic).
  if (o.dynamic_masks) {
    step("dynamic_masks", {{"frames", report.frames}}, exists(masks_dir), [&] {
      std::vector<cv::Mat> bgr;
      std::vector<std::string> names;
      for (const fs::path& f : frames) {
        bgr.push_back(ReadImage(f).ToBgr8());
        names.push_back(f.filename().string());
      }
      DynamicMaskStats stats;
      const std::vector<cv::Mat> masks = ComputeDynamicMasks(bgr, {}, &stats);
      fs::remove_all(masks_dir);
      WriteColmapMasks(masks, names, masks_dir);
      WriteDynamicMasks(masks, names, workspace.dynamic_masks());
      PANO4D_LOG(kInfo) << "sfm: " << stats.BriefReport();
    });
  }
  // Each frame's moving share, from the mask files (this run's or an
  // earlier one's).
  std::map<std::string, double> moving_fraction;
  if (o.dynamic_masks) {
    double sum = 0;
    for (const fs::path& f : frames) {
      const std::string name = f.filename().string();
      const cv::Mat mask =
          ReadMask(MaskPathFor(workspace.dynamic_masks(), name));
      moving_fraction[name] =
          cv::countNonZero(mask) / static_cast<double>(mask.total());
      sum += moving_fraction[name];
    }
    report.mean_dynamic_fraction = sum / frames.size();
  }

  // 3. Features (SIFT on the CPU), 4. matches, 5. mapper.
  const std::string matcher =
      !o.matcher.empty() ? o.matcher
                         : (!o.video.empty() ? "sequential" : "exhaustive");
  const std::vector<KnownFrame> known = KeptKnownFrames(o);
  const bool known_shared = !known.empty() && SameCamera(known);
  const std::string camera_model =
      known.empty() ? o.camera_model
                    : std::string(known.front().camera.camera.info().name);
  const bool single_camera = known.empty() ? o.single_camera : known_shared;
  const fs::path image_list = workspace.image_list();
  step("feature_extractor",
       {{"camera_model", camera_model},
        {"single_camera", single_camera},
        {"masks", o.dynamic_masks},
        {"known", !known.empty()}},
       exists(database), [&] {
         fs::remove(database);
         FeatureExtractorSettings settings;
         settings.database = database;
         settings.images = images_dir;
         settings.camera_model = camera_model;
         settings.single_camera = single_camera;
         if (o.dynamic_masks) settings.masks = masks_dir;
         if (!known.empty()) {
           // The known frames only (the database maps them by name); the
           // known camera where it is shared.
           std::string list;
           for (const KnownFrame& f : known) list += f.name + "\n";
           WriteFileAtomically(image_list, list);
           settings.image_list = image_list;
           if (known_shared) {
             for (const double p : known.front().camera.camera.params) {
               char buffer[32];
               std::snprintf(buffer, sizeof(buffer), "%.17g", p);
               if (!settings.camera_params.empty())
                 settings.camera_params += ',';
               settings.camera_params += buffer;
             }
           }
         }
         colmap.Run("feature_extractor", FeatureExtractorArgs(settings),
                    logs / "feature_extractor.log",
                    "check that the frames are readable images");
       });
  if (matcher == "sequential") CheckSequentialOrder(database, frame_names);
  step(matcher + "_matcher", {{"matcher", matcher}}, exists(database), [&] {
    colmap.Run(matcher + "_matcher", MatcherArgs(database),
               logs / (matcher + "_matcher.log"),
               "out of memory on many images: use --matcher sequential");
  });
  if (!known.empty()) {
    step(
        "point_triangulator", {{"frames", report.frames}},
        [&] { return DetectModelFormat(sparse / "0").has_value(); },
        [&] {
          const fs::path input = workspace.known_model();
          fs::remove_all(input);
          WriteModel(KnownModel(known, database), input, ColmapFormat::kText);
          fs::remove_all(sparse);
          EnsureDirectory(sparse / "0");
          // The poses and intrinsics are given: only points are estimated.
          colmap.Run(
              "point_triangulator",
              PointTriangulatorArgs(database, images_dir, input, sparse / "0"),
              logs / "point_triangulator.log",
              matcher == "exhaustive"
                  ? "too few matches between frames with known poses, with "
                    "every pair already matched: frames this small or this "
                    "plain give too few features (a lower --factor keeps "
                    "more pixels)"
                  : "too few matches between frames with known poses: try "
                    "--matcher exhaustive");
        });
  } else {
    step(
        "mapper", {{"frames", report.frames}, {"options", RelaxedMapperArgs()}},
        [&] { return DetectModelFormat(sparse / "0").has_value(); },
        [&] {
          fs::remove_all(sparse);
          EnsureDirectory(sparse);
          // Nothing posed: the diagnosis says why, in place of a generic
          // remedy.
          const auto nothing_posed = [&](const std::string& colmap_said) {
            const SfmDiagnosis d =
                DiagnoseSfm(ReadFrameEvidence(database, {}, moving_fraction));
            return Error(
                "colmap", "mapper",
                "0 of " + std::to_string(report.frames) + " frames posed",
                "Cause: " + d.Cause() + ". To try: " + d.Remedy() + " (" +
                    colmap_said + ")");
          };
          // A camera that only turns, or stands still: the rotation-only
          // model instead.
          const Image first = ReadImage(frames.front());
          if (TryRotationOnlyModel(database, first.width(), first.height(),
                                   sparse / "0"))
            return;
          try {
            colmap.Run("mapper", MapperArgs(database, images_dir, sparse),
                       logs / "mapper.log");
          } catch (const Error& e) {
            throw nothing_posed(e.problem());
          }
          if (SelectLargestModel(sparse) == 0) {
            throw nothing_posed("colmap mapper wrote no model; log: " +
                                (logs / "mapper.log").string());
          }
        });
    // Frames the mapper left out, posed by PnP against its points; the
    // log file says how many, for a later run that skips the step.
    const fs::path left_out_json = logs / "register_left_out.json";
    step(
        "register_left_out", {{"frames", report.frames}},
        [&] {
          return fs::exists(left_out_json) &&
                 DetectModelFormat(sparse / "0").has_value();
        },
        [&] {
          ColmapModel model = ReadModel(sparse / "0");
          const LeftOutReport left_out =
              RegisterLeftOutFrames(database, &model);
          if (!left_out.posed.empty()) {
            // The whole model swapped in at once: a killed run leaves the
            // mapper's model or this one, never a mixture.
            const fs::path next = sparse / "0.left_out";
            fs::remove_all(next);
            WriteModel(model, next, ColmapFormat::kBinary);
            fs::remove_all(sparse / "0");
            fs::rename(next, sparse / "0");
          }
          WriteJson(left_out_json, {{"left_out", left_out.left_out},
                                    {"posed", left_out.posed}});
        });
    report.posed_by_pnp = static_cast<int>(
        GetJson<Json>(ReadJson(left_out_json), "posed", left_out_json.string())
            .size());
  }
  report.models = static_cast<int>(ModelFolders(sparse).size());
  report.model = sparse / "0";
  report.images = images_dir;

  // 6. Undistortion, so that later stages see pinhole cameras.
  const ColmapModel mapped = ReadModel(report.model);
  const bool distorted = std::any_of(
      mapped.cameras.begin(), mapped.cameras.end(), [](const ColmapCamera& c) {
        return c.model_id != static_cast<int>(CameraModelId::kSimplePinhole) &&
               c.model_id != static_cast<int>(CameraModelId::kPinhole);
      });
  if (distorted) {
    const fs::path out = workspace.undistorted();
    step(
        "image_undistorter", {{"model_images", mapped.images.size()}},
        [&] { return DetectModelFormat(out / "sparse").has_value(); },
        [&] {
          fs::remove_all(out);
          colmap.Run("image_undistorter",
                     ImageUndistorterArgs(images_dir, report.model, out),
                     logs / "image_undistorter.log",
                     "check free disk space in the workspace");
        });
    report.model = out / "sparse";
    report.images = out / "images";
  }

  const ColmapModel model = ReadModel(report.model);
  report.rotation_only = IsRotationOnly(model);
  report.static_camera = IsStaticCamera(model);
  report.registered = static_cast<int>(model.images.size());
  report.points3D = static_cast<int>(model.points3D.size());
  double error_sum = 0;
  for (const ColmapPoint3D& p : model.points3D) error_sum += p.error;
  report.mean_reprojection_error =
      model.points3D.empty() ? 0.0 : error_sum / model.points3D.size();
  std::set<std::string> posed;
  for (const ColmapImage& image : model.images) posed.insert(image.name);
  report.diagnosis =
      DiagnoseSfm(ReadFrameEvidence(database, posed, moving_fraction));
  // Frames the database lacks (never imported) are unposed too.
  report.diagnosis.frames = std::max(report.diagnosis.frames, report.frames);

  nlohmann::json summary = {
      {"frames", report.frames},
      {"registered", report.registered},
      {"posed_by_pnp", report.posed_by_pnp},
      {"posed_fraction", report.diagnosis.PosedFraction()},
      {"camera_motion", report.CameraMotion()},
      {"diagnosis", report.diagnosis.ToJson()},
      {"points3D", report.points3D},
      {"mean_reprojection_error_px", report.mean_reprojection_error},
      {"models", report.models},
      {"model", fs::relative(report.model, ws).string()},
      {"images", fs::relative(report.images, ws).string()},
      {"camera_model", o.camera_model},
      {"matcher", matcher},
      {"dynamic_masks", o.dynamic_masks},
      {"mean_dynamic_fraction", report.mean_dynamic_fraction},
      {"options", o.ToJson()}};
  // Rewritten only when it says something new: the depth stage's stamp
  // records its modification time.
  const std::string text = summary.dump(2) + "\n";
  if (!fs::exists(workspace.sfm_json()) ||
      ReadTextFile(workspace.sfm_json()) != text)
    WriteFileAtomically(workspace.sfm_json(), text);
  WriteFileAtomically(logs / "timings.json", timings.dump(2) + "\n");
  return report;
}

}  // namespace pano4d
