#include "evaluation/evaluate.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "evaluation/lpips.h"
#include "evaluation/metrics.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/progress.h"
#include "src/core/strings.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

enum Key {
  kPsnr,
  kSsim,
  kLpips,
  kMpsnr,
  kMssim,
  kMlpips,
  kUpsnr,
  kUssim,
  kUlpips,
  kMssimStrict,
  kUssimStrict
};

fs::path RenderPath(const fs::path& renders, const std::string& id) {
  for (const char* ext : {".png", ".jpg", ".jpeg", ".exr"}) {
    const fs::path p = renders / (id + ext);
    if (fs::exists(p)) return p;
  }
  return {};
}

std::string Size(const Image& image) {
  return SizeText(image.width(), image.height());
}

std::string Cell(const std::optional<double>& v, const char* format) {
  if (!v) return "n/a";
  if (!std::isfinite(*v)) return *v > 0 ? "inf" : "-inf";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), format, *v);
  return buffer;
}

std::string BenchmarkFile(const std::string& kind) {
  if (kind == "dycheck") return "dycheck_iphone.json";
  if (kind == "nvidia") return "nvidia_dynamic_scenes.json";
  if (kind == "kubric4d") return "kubric4d.json";
  return "";
}

// Letters and digits, lower case: "nvidia-balloon1" -> "nvidiaballoon1".
std::string Normalised(const std::string& name) {
  std::string out;
  for (const char c : name)
    if (std::isalnum(static_cast<unsigned char>(c)))
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

PublishedRow RowOf(const Json& row, const std::string& source, bool mean) {
  PublishedRow r;
  r.method = row.value("method", "?");
  r.source = source;
  r.mean = mean;
  r.values = MetricRowFromJson(row);
  return r;
}

// The table rows for `rows`: the method, its source, then the nine columns.
void AppendRows(std::ostringstream& out,
                const std::vector<const PublishedRow*>& rows) {
  for (const PublishedRow* row : rows) {
    out << "| " << row->method << " (" << row->source << ") |";
    for (std::size_t k = 0; k < 9; ++k) {
      out << " "
          << (row->values[k] ? Cell(row->values[k], MetricFormat(k))
                             : std::string("-"))
          << " |";
    }
    out << "\n";
  }
}

const char* kTableHead =
    "| Method | PSNR | SSIM | LPIPS | mPSNR | mSSIM | mLPIPS | uPSNR | "
    "uSSIM | uLPIPS |\n|---|---|---|---|---|---|---|---|---|---|\n";

}  // namespace

Json MetricRowJson(const MetricRow& row) {
  Json j = Json::object();
  for (std::size_t k = 0; k < kNumMetrics; ++k) {
    const std::optional<double>& v = row[k];
    j[kMetricKeys[k]] = v && std::isfinite(*v) ? Json(*v) : Json(nullptr);
  }
  return j;
}

MetricRow MetricRowFromJson(const Json& object) {
  MetricRow row;
  for (std::size_t k = 0; k < kNumMetrics; ++k) {
    const char* key = kMetricKeys[k];
    if (object.contains(key) && object[key].is_number())
      row[k] = object[key].get<double>();
  }
  return row;
}

const char* MetricFormat(std::size_t key) {
  const std::string name = kMetricKeys[key];
  return name.find("psnr") != std::string::npos ? "%.2f" : "%.3f";
}

namespace {

// Each frame's render, all of them there before any scoring: a mean over
// the frames that happen to exist would not be comparable with anyone's
// numbers.
std::vector<fs::path> RequireRenders(const std::vector<DatasetFrame>& frames,
                                     const fs::path& renders,
                                     const std::string& split) {
  if (!fs::is_directory(renders))
    throw Error::In(renders.string(), "is not a directory of renders");
  std::vector<fs::path> render_paths;
  int missing = 0;
  std::string first_missing;
  for (const DatasetFrame& f : frames) {
    render_paths.push_back(RenderPath(renders, f.id));
    if (render_paths.back().empty() && missing++ == 0) first_missing = f.id;
  }
  if (missing > 0) {
    throw Error::In(renders.string(),
                    std::to_string(missing) + " of " +
                        std::to_string(frames.size()) +
                        " renders are missing (first: " + first_missing +
                        ".png); render every " + split + " frame");
  }
  return render_paths;
}

// What a frame's covisible mask left out: frames with one, and those whose
// mask leaves no covisible or no unseen pixel.
struct MaskCounts {
  int with_mask = 0, empty_covisible = 0, empty_unseen = 0;
};

// One frame's metrics (`truth` is f.rgb read): on every pixel, and with a
// covisible mask on the covisible (m*) and unseen (u*) pixels.
FrameMetrics ScoreFrame(const DatasetFrame& f, const Image& truth,
                        const Image& render, const fs::path& render_path,
                        const std::optional<Lpips>& lpips, MaskCounts* counts) {
  if (render.width() != truth.width() || render.height() != truth.height()) {
    throw Error(render_path.string(), "size", Size(render),
                "expected " + Size(truth) + " like " + f.rgb.string());
  }
  const cv::Mat a = QuantizeForMetrics(render, render_path.string());
  const cv::Mat b = QuantizeForMetrics(truth, f.rgb.string());
  FrameMetrics m;
  m.id = f.id;
  m.camera_id = f.camera_id;
  m.time_id = f.time_id;
  m.values[kPsnr] = Psnr(a, b);
  m.values[kSsim] = Ssim(a, b)->dycheck;
  // LPIPS of this render (a failure names it).
  const auto lpips_score = [&](const cv::Mat& mask) {
    try {
      return lpips->Score(a, b, mask);
    } catch (const Error& e) {
      throw Error(render_path.string(), "lpips", "", e.what());
    }
  };
  if (lpips) m.values[kLpips] = lpips_score({});
  if (f.covisible.empty()) return m;
  ++counts->with_mask;
  const cv::Mat raw = ReadMask(f.covisible);
  if (raw.size() != truth.mat().size()) {
    throw Error(f.covisible.string(), "size", SizeText(raw.cols, raw.rows),
                "expected " + Size(truth) + " like " + f.rgb.string());
  }
  const cv::Mat covisible = MetricMask(raw, f.covisible.string());
  const cv::Mat unseen = InvertMask(covisible);
  m.covisible_fraction = cv::mean(covisible)[0];
  m.values[kMpsnr] = Psnr(a, b, covisible);
  m.values[kUpsnr] = Psnr(a, b, unseen);
  if (lpips) {
    m.values[kMlpips] = lpips_score(covisible);
    m.values[kUlpips] = lpips_score(unseen);
  }
  if (const auto s = Ssim(a, b, covisible)) {
    m.values[kMssim] = s->dycheck;
    m.values[kMssimStrict] = s->strict;
  } else {
    ++counts->empty_covisible;
  }
  if (const auto s = Ssim(a, b, unseen)) {
    m.values[kUssim] = s->dycheck;
    m.values[kUssimStrict] = s->strict;
  } else {
    ++counts->empty_unseen;
  }
  return m;
}

// The mean of every pixel of the training frames.
std::optional<std::array<double, 3>> MeanTrainingColour(
    const std::vector<DatasetFrame>& train) {
  cv::Scalar sum = cv::Scalar::all(0);
  double pixels = 0;
  for (const DatasetFrame& f : train) {
    const Image image = ReadImage(f.rgb);
    const double n = static_cast<double>(image.width()) * image.height();
    sum += cv::mean(image.mat()) * n;
    pixels += n;
  }
  if (pixels == 0) return std::nullopt;
  return std::array<double, 3>{sum[0] / pixels, sum[1] / pixels,
                               sum[2] / pixels};
}

// The mean of each metric over the frames that define it.
MetricRow MeanOver(const std::vector<FrameMetrics>& frames,
                   std::array<int, kNumMetrics>* used) {
  MetricRow mean;
  for (std::size_t k = 0; k < kNumMetrics; ++k) {
    double sum = 0;
    int n = 0;
    for (const FrameMetrics& m : frames) {
      if (m.values[k]) {
        sum += *m.values[k];
        ++n;
      }
    }
    if (used) (*used)[k] = n;
    if (n > 0) mean[k] = sum / n;
  }
  return mean;
}

// Each frame of `frames` painted with the training frames' mean colour,
// scored as a render.
std::optional<MeanColourFloor> ScoreMeanColour(
    const std::vector<DatasetFrame>& train,
    const std::vector<DatasetFrame>& frames) {
  const std::optional<std::array<double, 3>> rgb = MeanTrainingColour(train);
  if (!rgb) return std::nullopt;
  MeanColourFloor floor;
  floor.rgb = *rgb;
  std::vector<FrameMetrics> scored;
  MaskCounts ignored;
  for (const DatasetFrame& f : frames) {
    const Image truth = ReadImage(f.rgb);
    Image constant(truth.width(), truth.height());
    constant.mat().setTo(cv::Scalar((*rgb)[0], (*rgb)[1], (*rgb)[2]));
    scored.push_back(ScoreFrame(f, truth, constant, "the mean training colour",
                                std::nullopt, &ignored));
  }
  floor.mean = MeanOver(scored, nullptr);
  return floor;
}

// What a reader of the means must know: the LPIPS weights, DyCheck's SSIM,
// which frames m* and u* cover, infinite PSNR.
std::vector<std::string> EvaluationNotes(const EvaluationResult& result,
                                         const EvaluateOptions& options,
                                         bool lpips, const MaskCounts& counts) {
  std::vector<std::string> notes;
  notes.push_back(
      lpips ? "LPIPS: AlexNet v0.1, the spatial map averaged over the mask "
              "with both images multiplied by it (as DyCheck); weights from " +
                  options.lpips_weights.string()
            : std::string("LPIPS: n/a, no AlexNet LPIPS weights were given "
                          "(--lpips-weights; see "
                          "scripts/lpips_weights_from_torch.py)"));
  notes.push_back(
      "SSIM columns are DyCheck's masked SSIM, in which windows wholly outside "
      "the mask count as "
      "1.0; mssim_strict and ussim_strict average only windows that touch the "
      "mask");
  const int frames = static_cast<int>(result.frames.size());
  if (counts.with_mask == 0) {
    notes.push_back(
        "m* and u*: n/a, the dataset has no covisible masks for this split");
  } else if (counts.with_mask < frames) {
    notes.push_back("m* and u* are over the " +
                    std::to_string(counts.with_mask) +
                    " frames that have a covisible mask");
  }
  if (counts.empty_covisible > 0 || counts.empty_unseen > 0) {
    notes.push_back(
        std::to_string(counts.empty_unseen) +
        " frames have no unseen pixel and " +
        std::to_string(counts.empty_covisible) +
        " no covisible pixel; they are left out of u* and m* respectively");
  }
  for (const FrameMetrics& m : result.frames) {
    if (m.values[kPsnr] && std::isinf(*m.values[kPsnr])) {
      notes.push_back(
          "some frames are identical to the ground truth (PSNR +inf); JSON "
          "holds null for infinite values");
      break;
    }
  }
  return notes;
}

}  // namespace

EvaluationResult EvaluateRenders(const Dataset& dataset,
                                 const fs::path& renders,
                                 const EvaluateOptions& options) {
  if (options.split != "val" && options.split != "train") {
    throw Error("--split", "", options.split, "use val or train");
  }
  std::optional<Lpips> lpips;
  if (!options.lpips_weights.empty()) {
    lpips = Lpips::Load(options.lpips_weights);
  }
  const std::vector<DatasetFrame>& frames =
      options.split == "val" ? dataset.val : dataset.train;
  if (frames.empty()) {
    throw Error(dataset.root.string(), "split", options.split,
                "has no frames to evaluate");
  }
  const std::vector<fs::path> render_paths =
      RequireRenders(frames, renders, options.split);

  EvaluationResult result;
  result.dataset = dataset.root.string();
  result.scene = dataset.scene;
  result.protocol = SplitDescription(dataset);
  result.kind = std::string(ToString(dataset.kind));
  result.split = options.split;
  result.factor = dataset.factor;
  ProgressBar progress("eval " + options.split,
                       static_cast<std::int64_t>(frames.size()));
  MaskCounts counts;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    result.frames.push_back(ScoreFrame(frames[i], ReadImage(frames[i].rgb),
                                       ReadImage(render_paths[i]),
                                       render_paths[i], lpips, &counts));
    progress.Add();
  }
  progress.Finish();
  result.mean = MeanOver(result.frames, &result.frames_used);
  result.floor = ScoreMeanColour(dataset.train, frames);
  result.notes = EvaluationNotes(result, options, lpips.has_value(), counts);
  return result;
}

Json EvaluationJson(const EvaluationResult& r) {
  const Json mean = MetricRowJson(r.mean);
  Json used = Json::object();
  for (std::size_t k = 0; k < kNumMetrics; ++k)
    used[kMetricKeys[k]] = r.frames_used[k];
  Json floor;
  if (r.floor) {
    floor = {{"rgb", r.floor->rgb}, {"mean", MetricRowJson(r.floor->mean)}};
  }
  return Json{{"dataset", r.dataset},      {"scene", r.scene},
              {"protocol", r.protocol},    {"kind", r.kind},
              {"split", r.split},          {"factor", r.factor},
              {"frames", r.frames.size()}, {"mean", mean},
              {"frames_used", used},       {"mean_colour_floor", floor},
              {"notes", r.notes}};
}

std::string EvaluationCsv(const EvaluationResult& r) {
  std::ostringstream out;
  out << "id,camera_id,time_id,covisible_fraction";
  for (const char* key : kMetricKeys) out << "," << key;
  out << "\n";
  for (const FrameMetrics& m : r.frames) {
    out << m.id << "," << m.camera_id << "," << m.time_id << ",";
    if (m.covisible_fraction >= 0) out << Cell(m.covisible_fraction, "%.6f");
    for (const auto& v : m.values) out << "," << (v ? Cell(v, "%.6f") : "");
    out << "\n";
  }
  return out.str();
}

std::string EvaluationMarkdown(const EvaluationResult& r,
                               const std::vector<PublishedRow>& published,
                               bool benchmark_known) {
  std::ostringstream out;
  out << "# pano4d evaluation: " << r.kind << " scene " << r.scene << ", split "
      << r.split << ", " << r.frames.size() << " frames at " << r.factor
      << "x\n\n"
      << "Protocol: " << r.protocol << "\n\n";
  std::vector<const PublishedRow*> scene_rows, mean_rows;
  for (const PublishedRow& row : published)
    (row.mean ? mean_rows : scene_rows).push_back(&row);
  out << "## This scene\n\n" << kTableHead << "| pano4d |";
  for (std::size_t k = 0; k < 9; ++k)
    out << " " << Cell(r.mean[k], MetricFormat(k)) << " |";
  out << "\n";
  if (r.floor) {
    out << "| mean training colour (floor) |";
    for (std::size_t k = 0; k < 9; ++k) {
      out << " "
          << (r.floor->mean[k] ? Cell(r.floor->mean[k], MetricFormat(k))
                               : std::string("-"))
          << " |";
    }
    out << "\n";
  }
  AppendRows(out, scene_rows);
  if (scene_rows.empty())
    out << "\nNo published per-scene rows for this scene in datasets_meta/.\n";
  if (!mean_rows.empty()) {
    out << "\n## Means over the benchmark's scenes (not comparable with one "
           "scene's numbers)\n\n"
        << kTableHead;
    AppendRows(out, mean_rows);
  }
  out << "\nStrict masked SSIM (only windows that touch the mask): mSSIM "
      << Cell(r.mean[kMssimStrict], "%.3f") << ", uSSIM "
      << Cell(r.mean[kUssimStrict], "%.3f") << "\n\n";
  if (r.floor && r.mean[kUpsnr] && r.floor->mean[kUpsnr]) {
    out << "uPSNR against the floor of the mean training colour: "
        << Cell(r.mean[kUpsnr], "%.2f") << " against "
        << Cell(r.floor->mean[kUpsnr], "%.2f") << " ("
        << Cell(*r.mean[kUpsnr] - *r.floor->mean[kUpsnr], "%+.2f")
        << " dB)\n\n";
  }
  for (const std::string& note : r.notes) out << "- " << note << "\n";
  if (!benchmark_known)
    out << "- no published rows: datasets_meta/ has no file for this kind\n";
  return out.str();
}

Json BenchmarkMeta(const fs::path& datasets_meta, const std::string& kind) {
  const std::string file = BenchmarkFile(kind);
  if (file.empty() || !fs::exists(datasets_meta / file)) return Json();
  return ReadJson(datasets_meta / file);
}

std::vector<PublishedRow> PublishedRows(const Json& benchmark,
                                        const std::string& scene) {
  std::vector<PublishedRow> rows;
  if (!benchmark.is_object()) return rows;
  const std::string name = Normalised(scene);
  const Json sources = benchmark.value("per_scene_published", Json::array());
  for (const Json& source : sources) {
    // The source's first words name it in the table ("DynamicNeRF README").
    std::string label = source.value("source", "published");
    label = label.substr(0, label.find(" ("));
    const Json scenes = source.value("scenes", Json::object());
    for (const auto& [key, list] : scenes.items()) {
      const std::string k = Normalised(key);
      if (name.size() < k.size() ||
          name.compare(name.size() - k.size(), k.size(), k) != 0)
        continue;
      for (const Json& row : list) rows.push_back(RowOf(row, label, false));
    }
  }
  for (const Json& source : sources) {
    std::string label = source.value("source", "published");
    label = label.substr(0, label.find(" (")) + ", mean";
    for (const Json& row : source.value("mean", Json::array()))
      rows.push_back(RowOf(row, label, true));
  }
  const Json paper = benchmark.value("paper", Json());
  if (paper.is_object() && paper.contains("rows")) {
    for (const Json& row : paper["rows"])
      rows.push_back(RowOf(row, "paper, mean", true));
  }
  return rows;
}

std::string WriteEvaluation(const EvaluationResult& r, const fs::path& out,
                            const fs::path& datasets_meta) {
  const Json benchmark = BenchmarkMeta(datasets_meta, r.kind);
  WriteFileAtomically(out / "per_frame.csv", EvaluationCsv(r));
  WriteJson(out / "metrics.json", EvaluationJson(r));
  const std::string markdown = EvaluationMarkdown(
      r, PublishedRows(benchmark, r.scene), benchmark.is_object());
  WriteFileAtomically(out / "metrics.md", markdown);
  return markdown;
}

}  // namespace pano4d
