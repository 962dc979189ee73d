// pano4d.scan_priors, read_priors and the write_* functions: learned priors
// read as `--priors` reads them (src/datasets/priors.h), and written by a
// script (a torch model in the same process) in layouts it reads
// (docs/formats.md, "Learned priors").
#include "src/python/module.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/npy.h"
#include "src/core/npz.h"
#include "src/core/workspace.h"
#include "src/datasets/priors.h"
#include "src/pipeline/priors.h"

namespace pano4d::python {
namespace {

namespace fs = std::filesystem;
namespace py = pybind11;

using FloatArray =
    py::array_t<float, py::array::c_style | py::array::forcecast>;

// A float array of `dims` dimensions (the last of size `last` when > 0),
// checked finite: what a reader would refuse is refused at the writer.
FloatArray Checked(const py::object& values, int dims, py::ssize_t last,
                   const std::string& what) {
  FloatArray a = FloatArray::ensure(values);
  if (!a || a.ndim() != dims || (last > 0 && a.shape(dims - 1) != last)) {
    throw Error::In(
        what,
        "must be a float array of " + std::to_string(dims) + " dimensions" +
            (last > 0 ? " ending in " + std::to_string(last) : std::string()));
  }
  const float* v = a.data();
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (!std::isfinite(v[i])) throw Error::In(what, "holds NaN or Inf");
  }
  return a;
}

NpyArray ToNpy(const FloatArray& a) {
  std::vector<std::int64_t> shape(a.shape(), a.shape() + a.ndim());
  return NpyArray::FromFloats(
      shape, std::vector<float>(a.data(), a.data() + a.size()));
}

// A bool/uint8 mask [H, W] as CV_8UC1 with kMaskOn where true.
cv::Mat MaskMat(const py::object& values, const std::string& what) {
  auto a = py::array_t<std::uint8_t, py::array::c_style |
                                         py::array::forcecast>::ensure(values);
  if (!a || a.ndim() != 2) {
    throw Error::In(what, "must be a 2-dimensional mask (bool or uint8)");
  }
  cv::Mat m(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)),
            CV_8UC1);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x)
      m.at<std::uint8_t>(y, x) = a.at(y, x) ? kMaskOn : 0;
  return m;
}

py::array_t<float> FromMat(const cv::Mat& m) {
  const int channels = m.channels();
  std::vector<py::ssize_t> shape{m.rows, m.cols};
  if (channels > 1) shape.push_back(channels);
  py::array_t<float> a(shape);
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  std::copy(c.ptr<float>(), c.ptr<float>() + m.total() * channels,
            a.mutable_data());
  return a;
}

py::array_t<bool> BoolFromMat(const cv::Mat& m) {
  py::array_t<bool> a({m.rows, m.cols});
  auto r = a.mutable_unchecked<2>();
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) r(y, x) = m.at<std::uint8_t>(y, x) != 0;
  return a;
}

py::object LayoutName(const PriorLayout* layout) {
  return layout ? py::object(py::str(layout->name)) : py::object(py::none());
}

}  // namespace

void AddPriorFunctions(py::module_& m) {
  m.def(
      "scan_priors",
      [](const py::object& dir) {
        return ToPython(ScanPriors(FsPath(dir)).ToJson());
      },
      py::arg("dir"),
      "The prior layouts a folder holds, as `pano4d dataset info` lists "
      "them: {'root', 'layouts': [{'kind', 'layout', 'holds', 'path', "
      "'files'}]}");

  m.def(
      "read_priors",
      [](const py::object& dir, const py::object& workspace) {
        const PriorsFolder folder = ScanPriors(FsPath(dir));
        const Workspace ws(FsPath(workspace));
        const WorkspaceFrames frames = ReadWorkspaceFrames(ws.root());
        const std::vector<PriorFrame> video = PriorVideoFrames(ws, frames);
        py::dict out;
        out["frames"] = [&] {
          py::list names;
          for (const PriorFrame& f : video) names.append(f.name);
          return names;
        }();
        if (auto depth = ReadDepthPrior(folder, video)) {
          py::dict maps;
          for (std::size_t i = 0; i < video.size(); ++i)
            if (!depth->maps[i].empty())
              maps[py::str(video[i].name)] = FromMat(depth->maps[i]);
          py::dict d;
          d["layout"] = LayoutName(depth->layout);
          d["meaning"] = depth->layout->meaning == DepthMeaning::kDisparity
                             ? "disparity"
                             : "metric depth";
          d["maps"] = maps;
          out["depth"] = d;
        }
        if (auto flow = ReadFlowPrior(folder, video)) {
          py::list fields;
          for (const FlowField& f : flow->fields) {
            py::dict d;
            d["from"] = video[f.from].name;
            d["to"] = video[f.to].name;
            d["flow"] = FromMat(f.flow);
            d["valid"] = BoolFromMat(f.valid);
            d["mask_source"] = f.mask_source;
            fields.append(d);
          }
          out["flow"] = py::dict(py::arg("layout") = LayoutName(flow->layout),
                                 py::arg("fields") = fields);
        }
        if (auto tracks = ReadTrackPrior(folder, video)) {
          const auto n = static_cast<py::ssize_t>(tracks->size());
          const py::ssize_t t = tracks->num_frames;
          py::array_t<float> pixels({t, n, py::ssize_t{2}});
          py::array_t<bool> visible({t, n});
          auto p = pixels.mutable_unchecked<3>();
          auto v = visible.mutable_unchecked<2>();
          for (py::ssize_t k = 0; k < n; ++k) {
            for (py::ssize_t f = 0; f < t; ++f) {
              const std::size_t i = static_cast<std::size_t>(k * t + f);
              p(f, k, 0) = tracks->pixels[i].x();
              p(f, k, 1) = tracks->pixels[i].y();
              v(f, k) = tracks->visible[i] != 0;
            }
          }
          out["tracks"] = py::dict(
              py::arg("layout") = LayoutName(tracks->layout),
              py::arg("pixels") = pixels, py::arg("visible") = visible);
        }
        if (auto masks = ReadMaskPrior(folder, video)) {
          py::dict maps;
          for (std::size_t i = 0; i < video.size(); ++i)
            if (!masks->masks[i].empty())
              maps[py::str(video[i].name)] = BoolFromMat(masks->masks[i]);
          out["masks"] = py::dict(py::arg("layout") = LayoutName(masks->layout),
                                  py::arg("maps") = maps);
        }
        return out;
      },
      py::arg("dir"), py::arg("workspace"),
      "The priors of a folder as a fit of `workspace` reads them: each "
      "kind's preferred layout, resized to the workspace's frames (video "
      "order, 'frames'): depth {'layout', 'meaning', 'maps': {frame: [H, "
      "W]}}, flow {'layout', 'fields': [{'from', 'to', 'flow' [H, W, 2], "
      "'valid' [H, W]}]}, tracks {'layout', 'pixels' [T, N, 2], 'visible' "
      "[T, N]}, masks {'layout', 'maps'}; a kind the folder lacks is absent");

  m.def(
      "write_disparity",
      [](const py::object& dir, const std::string& frame,
         const py::object& disparity) {
        const FloatArray a = Checked(disparity, 2, 0, "disparity of " + frame);
        const fs::path path = FsPath(dir) / "disp" / (frame + ".npy");
        EnsureDirectory(path.parent_path());
        WriteNpy(path, ToNpy(a));
        return path.string();
      },
      py::arg("dir"), py::arg("frame"), py::arg("disparity"),
      "DIR/disp/<frame>.npy (DynamicNeRF's layout): a monocular network's "
      "disparity [H, W], known up to a scale and shift per frame (MiDaS, "
      "Depth Anything); pano4d aligns it to the SfM points. frame: the "
      "frame's name or image stem. Returns the path");

  m.def(
      "write_flow",
      [](const py::object& dir, const std::string& from_image,
         const std::string& to_image, const py::object& flow,
         const py::object& valid) {
        const FloatArray a =
            Checked(flow, 3, 2, "flow " + from_image + " -> " + to_image);
        const std::string stem = from_image + "_" + to_image;
        cv::Mat mask;
        if (!valid.is_none()) {
          mask = MaskMat(valid, "valid of " + stem);
          if (mask.rows != a.shape(0) || mask.cols != a.shape(1)) {
            throw Error::In("valid of " + stem, "is not the flow's size");
          }
        }
        const fs::path path = FsPath(dir) / "raft_exhaustive" / (stem + ".npy");
        EnsureDirectory(path.parent_path());
        WriteNpy(path, ToNpy(a));
        if (!mask.empty()) {
          cv::Mat red(mask.size(), CV_8UC3, cv::Scalar(0, 0, 0));
          red.setTo(cv::Scalar(0, 0, 255), mask);  // BGR: red = consistent
          const fs::path mask_path =
              FsPath(dir) / "raft_masks" / (stem + ".png");
          EnsureDirectory(mask_path.parent_path());
          WritePng8(mask_path, red);
        }
        return path.string();
      },
      py::arg("dir"), py::arg("from_image"), py::arg("to_image"),
      py::arg("flow"), py::arg("valid") = py::none(),
      "DIR/raft_exhaustive/<from>_<to>.npy (OmniMotion's layout): optical "
      "flow [H, W, 2] in pixels from the image named from_image (its file "
      "name, e.g. 0_00000.png) to to_image; `valid` [H, W] (True where the "
      "flow is trusted) goes to raft_masks/, else pano4d checks it forward "
      "and backward when the reverse flow is there. Returns the path");

  m.def(
      "write_mask",
      [](const py::object& dir, const std::string& frame,
         const py::object& moving) {
        const fs::path path = FsPath(dir) / "motion_masks" / (frame + ".png");
        EnsureDirectory(path.parent_path());
        WriteMask(path, MaskMat(moving, "mask of " + frame));
        return path.string();
      },
      py::arg("dir"), py::arg("frame"), py::arg("moving"),
      "DIR/motion_masks/<frame>.png (DynamicNeRF's layout): True where "
      "something moves. Returns the path");

  m.def(
      "write_tracks",
      [](const py::object& dir, const py::object& pixels,
         const py::object& visible, const std::string& name) {
        const FloatArray p = Checked(pixels, 3, 2, "tracks");
        auto v = py::array_t<std::uint8_t,
                             py::array::c_style |
                                 py::array::forcecast>::ensure(visible);
        if (!v || v.ndim() != 2 || v.shape(0) != p.shape(0) ||
            v.shape(1) != p.shape(1)) {
          throw Error::In("visible",
                          "must be [T, N], the tracks' first two sizes");
        }
        NpyArray vis;
        vis.kind = 'b';
        vis.item_size = 1;
        vis.shape = {v.shape(0), v.shape(1)};
        vis.data.resize(static_cast<std::size_t>(v.size()));
        for (py::ssize_t i = 0; i < v.size(); ++i)
          vis.data[static_cast<std::size_t>(i)] = v.data()[i] ? 1 : 0;
        const fs::path path = FsPath(dir) / name;
        EnsureDirectory(path.parent_path());
        WriteNpz(path, {{"tracks", ToNpy(p)}, {"visibility", vis}});
        return path.string();
      },
      py::arg("dir"), py::arg("pixels"), py::arg("visible"),
      py::arg("name") = "tracks.npz",
      "DIR/<name> (CoTracker's arrays): pixels [T, N, 2] of N points over "
      "the video's T frames and visible [T, N]. Returns the path");
}

}  // namespace pano4d::python
