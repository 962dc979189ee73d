// The Python module `pano4d`, in the manner of pycolmap: a workspace's
// frames, cameras, depth and summaries, the fitted scene at a time and its
// renders as NumPy arrays, and the stages as functions that take the
// command line's options as keyword arguments (docs/python.md).
//
// The stages are in stages.cc, the learned priors in priors.cc. Renders run
// with the GIL released.
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/version.h"
#include "src/core/workspace.h"
#include "src/gs/checkpoint.h"
#include "src/gs/scene.h"
#include "src/pano/trajectory.h"
#include "src/pipeline/scene_outputs.h"
#include "src/python/module.h"
#include "src/render/sh.h"

namespace py = pybind11;

namespace pano4d::python {

py::object ToPython(const Json& j) {
  switch (j.type()) {
    case Json::value_t::object: {
      py::dict d;
      for (const auto& [k, v] : j.items()) d[py::str(k)] = ToPython(v);
      return d;
    }
    case Json::value_t::array: {
      py::list l;
      for (const Json& v : j) l.append(ToPython(v));
      return l;
    }
    case Json::value_t::string:
      return py::str(j.get<std::string>());
    case Json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case Json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case Json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case Json::value_t::number_float:
      return py::float_(j.get<double>());
    default:
      return py::none();
  }
}

std::filesystem::path FsPath(py::handle path) {
  return py::module_::import("os").attr("fspath")(path).cast<std::string>();
}

py::object ReadJsonOrNone(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) return py::none();
  return ToPython(ReadJson(path));
}

namespace {

namespace fs = std::filesystem;

// A float vector of `rows` x `cols` (cols 0: one column) as a NumPy array
// that shares its memory with `owner` (a Python object that keeps it).
py::array_t<float> View(const std::vector<float>& v, std::size_t rows,
                        std::vector<py::ssize_t> tail, py::handle owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(rows)};
  shape.insert(shape.end(), tail.begin(), tail.end());
  return py::array_t<float>(shape, v.data(), owner);
}

py::array_t<std::uint8_t> Rgb8(const cv::Mat& bgr8) {
  py::array_t<std::uint8_t> a({bgr8.rows, bgr8.cols, 3});
  auto r = a.mutable_unchecked<3>();
  for (int y = 0; y < bgr8.rows; ++y) {
    for (int x = 0; x < bgr8.cols; ++x) {
      const cv::Vec3b& p = bgr8.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) r(y, x, c) = p[2 - c];
    }
  }
  return a;
}

py::dict FrameDict(const WorkspaceFrame& f, const char* split) {
  const auto path = [](const fs::path& p) -> py::object {
    return p.empty() ? py::object(py::none()) : py::object(py::str(p.string()));
  };
  py::dict d;
  d["name"] = f.name;
  d["time"] = f.time;
  d["split"] = split;
  d["camera"] = RasterCamera::FromPosed(f.camera);
  d["rgb"] = path(f.rgb);
  d["depth"] = path(f.depth);
  d["dynamic_mask"] = path(f.dynamic_mask);
  d["covisible"] = path(f.covisible);
  return d;
}

// The scene's Gaussians at a time (GaussianScene::ComposeAt) and what a
// user reads off them. The parameters are views of the composed model,
// which their NumPy base keeps alive.
py::dict SceneAt(const GaussianScene& scene, int time) {
  if (time < 0 || time >= scene.num_times) {
    throw Error("scene_at", "time", std::to_string(time),
                "must be in [0, " + std::to_string(scene.num_times) +
                    "), the fitted scene's times");
  }
  auto model = std::make_unique<GaussianModel>();
  scene.ComposeAt(time, model.get());
  const GaussianModel& m = *model;
  py::capsule owner(model.release(),
                    [](void* p) { delete static_cast<GaussianModel*>(p); });
  const std::size_t n = m.size();
  const py::ssize_t k = m.sh_coefficients();
  py::dict d;
  d["means"] = View(m.means, n, {3}, owner);
  d["log_scales"] = View(m.log_scales, n, {3}, owner);
  d["quats"] = View(m.quats, n, {4}, owner);
  d["opacity_logits"] = View(m.opacities, n, {}, owner);
  d["sh"] = View(m.sh, n, {k, 3}, owner);
  py::array_t<float> scales({static_cast<py::ssize_t>(n), py::ssize_t{3}});
  py::array_t<float> rotations({static_cast<py::ssize_t>(n), py::ssize_t{4}});
  py::array_t<float> opacities(static_cast<py::ssize_t>(n));
  py::array_t<float> colours({static_cast<py::ssize_t>(n), py::ssize_t{3}});
  py::array_t<bool> dynamic(static_cast<py::ssize_t>(n));
  auto s = scales.mutable_unchecked<2>();
  auto r = rotations.mutable_unchecked<2>();
  auto o = opacities.mutable_unchecked<1>();
  auto c = colours.mutable_unchecked<2>();
  auto dy = dynamic.mutable_unchecked<1>();
  for (std::size_t i = 0; i < n; ++i) {
    const float* q = &m.quats[4 * i];
    const float norm =
        std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int j = 0; j < 3; ++j) s(i, j) = std::exp(m.log_scales[3 * i + j]);
    for (int j = 0; j < 4; ++j) r(i, j) = norm > 0 ? q[j] / norm : 0.0f;
    o(i) = 1.0f / (1.0f + std::exp(-m.opacities[i]));
    for (int j = 0; j < 3; ++j) {
      c(i, j) = static_cast<float>(kShC0) * m.sh[3 * k * i + j] + 0.5f;
    }
    dy(i) = i >= scene.statics.size();
  }
  d["scales"] = scales;
  d["rotations"] = rotations;
  d["opacities"] = opacities;
  d["colours"] = colours;
  d["dynamic"] = dynamic;
  return d;
}

}  // namespace
}  // namespace pano4d::python

PYBIND11_MODULE(pano4d, m) {
  using namespace pano4d;
  using namespace pano4d::python;
  m.doc() =
      "pano4d: a monocular video to a dynamic 4D Gaussian scene. The stages "
      "take the command line's options as keyword arguments "
      "(pano4d.help('fit') prints them); see docs/python.md.";
  m.attr("__version__") = kVersion;
  py::register_exception<Error>(m, "Error", PyExc_RuntimeError);

  py::class_<RasterCamera>(m, "Camera",
                           "A pinhole camera: intrinsics in pixels and the "
                           "world-to-camera rotation and translation")
      .def(py::init([](int width, int height, float fx, float fy, float cx,
                       float cy, const Eigen::Matrix3f& rotation,
                       const Eigen::Vector3f& translation) {
             RasterCamera c;
             c.width = width;
             c.height = height;
             c.fx = fx;
             c.fy = fy;
             c.cx = cx;
             c.cy = cy;
             c.rotation = rotation;
             c.translation = translation;
             return c;
           }),
           py::arg("width"), py::arg("height"), py::arg("fx"), py::arg("fy"),
           py::arg("cx"), py::arg("cy"),
           py::arg("rotation") = Eigen::Matrix3f::Identity().eval(),
           py::arg("translation") = Eigen::Vector3f::Zero().eval())
      .def_readwrite("width", &RasterCamera::width)
      .def_readwrite("height", &RasterCamera::height)
      .def_readwrite("fx", &RasterCamera::fx)
      .def_readwrite("fy", &RasterCamera::fy)
      .def_readwrite("cx", &RasterCamera::cx)
      .def_readwrite("cy", &RasterCamera::cy)
      .def_readwrite("rotation", &RasterCamera::rotation)
      .def_readwrite("translation", &RasterCamera::translation)
      .def_property_readonly("K",
                             [](const RasterCamera& c) {
                               Eigen::Matrix3f k = Eigen::Matrix3f::Identity();
                               k(0, 0) = c.fx;
                               k(1, 1) = c.fy;
                               k(0, 2) = c.cx;
                               k(1, 2) = c.cy;
                               return k;
                             })
      .def_property_readonly("world_to_camera",
                             [](const RasterCamera& c) {
                               Eigen::Matrix4f t = Eigen::Matrix4f::Identity();
                               t.topLeftCorner<3, 3>() = c.rotation;
                               t.topRightCorner<3, 1>() = c.translation;
                               return t;
                             })
      .def_property_readonly("center", &RasterCamera::Center)
      .def("__repr__", [](const RasterCamera& c) {
        return "Camera(" + std::to_string(c.width) + "x" +
               std::to_string(c.height) + ", fx=" + std::to_string(c.fx) + ")";
      });

  py::class_<GaussianScene, std::shared_ptr<GaussianScene>>(
      m, "Scene", "A fitted 4D Gaussian scene (a fit's checkpoint)")
      .def_readonly("num_times", &GaussianScene::num_times)
      .def_readonly("canonical_time", &GaussianScene::canonical_time)
      .def_property_readonly(
          "num_static", [](const GaussianScene& s) { return s.statics.size(); })
      .def_property_readonly(
          "num_dynamic",
          [](const GaussianScene& s) { return s.dynamics.size(); })
      .def_property_readonly(
          "num_bases", [](const GaussianScene& s) { return s.bases.num_bases; })
      .def("scene_at", &SceneAt, py::arg("t"),
           "The Gaussians at time t, static rows first: means, log_scales, "
           "quats (w x y z), opacity_logits and sh as views of the composed "
           "scene; scales, rotations (normalised), opacities, colours (the "
           "SH degree-0 colour) and the dynamic flag computed from them")
      .def(
          "motion_bases",
          [](std::shared_ptr<GaussianScene> s) {
            const py::object owner = py::cast(s);
            const MotionBases& b = s->bases;
            py::dict d;
            d["rotations"] =
                View(b.rotations, b.num_bases, {b.num_times, 4}, owner);
            d["translations"] =
                View(b.translations, b.num_bases, {b.num_times, 3}, owner);
            d["logits"] =
                View(s->logits, s->dynamics.size(), {b.num_bases}, owner);
            return d;
          },
          "The K motion bases (rotations [K, T, 4], translations [K, T, 3]) "
          "and the dynamic Gaussians' basis logits [M, K], as views");

  py::class_<Workspace>(m, "Workspace",
                        "A pano4d workspace: its frames, cameras, depth, "
                        "summaries and fitted scene")
      .def(py::init([](const py::object& path) {
             const fs::path p(FsPath(path));
             if (!fs::is_directory(p)) {
               throw Error::In(p.string(),
                               "is not a folder (a workspace is made by "
                               "pano4d.sfm, depth or run)");
             }
             return Workspace(p);
           }),
           py::arg("path"))
      .def_property_readonly(
          "root", [](const Workspace& w) { return w.root().string(); })
      .def(
          "frames",
          [](const Workspace& w, const std::string& split) {
            const WorkspaceFrames f = ReadWorkspaceFrames(w.root());
            if (split != "train" && split != "val") {
              throw Error("frames", "split", split, "must be train or val");
            }
            py::list out;
            for (const WorkspaceFrame& frame :
                 split == "train" ? f.train : f.val)
              out.append(FrameDict(frame, split.c_str()));
            return out;
          },
          py::arg("split") = "train",
          "The frames of frames.json: name, time, camera, and the paths of "
          "rgb, depth, dynamic_mask, covisible (None when absent)")
      .def_property_readonly("num_times",
                             [](const Workspace& w) {
                               return ReadWorkspaceFrames(w.root()).num_times;
                             })
      .def(
          "image",
          [](const Workspace& w, const std::string& name) {
            const WorkspaceFrames f = ReadWorkspaceFrames(w.root());
            for (const auto* list : {&f.train, &f.val})
              for (const WorkspaceFrame& frame : *list)
                if (frame.name == name)
                  return Rgb8(ReadImage(frame.rgb).ToBgr8());
            throw Error(w.frames_json().string(), "frame", name,
                        "is not one of its frames");
          },
          py::arg("name"), "A frame's image, RGB uint8 [H, W, 3]")
      .def(
          "depth",
          [](const Workspace& w, const std::string& name) -> py::object {
            const fs::path p = w.depth_map(name);
            if (!fs::exists(p)) {
              throw Error::In(p.string(),
                              "missing: pano4d.depth writes the frames' "
                              "depth maps");
            }
            return py::module_::import("numpy").attr("load")(p.string());
          },
          py::arg("name"), "A frame's z-depth map [H, W] (0: none)")
      .def(
          "dynamic_mask",
          [](const Workspace& w, const std::string& name) -> py::object {
            const WorkspaceFrames f = ReadWorkspaceFrames(w.root());
            for (const WorkspaceFrame& frame : f.train) {
              if (frame.name != name) continue;
              if (frame.dynamic_mask.empty()) return py::none();
              const cv::Mat bgr = ReadImage(frame.dynamic_mask).ToBgr8();
              py::array_t<bool> a({bgr.rows, bgr.cols});
              auto r = a.mutable_unchecked<2>();
              for (int y = 0; y < bgr.rows; ++y)
                for (int x = 0; x < bgr.cols; ++x)
                  r(y, x) = bgr.at<cv::Vec3b>(y, x)[0] >= 128;
              return a;
            }
            throw Error(w.frames_json().string(), "training frame", name,
                        "is not one of its training frames");
          },
          py::arg("name"),
          "A training frame's dynamic mask, bool [H, W] (True: moving), or "
          "None")
      .def(
          "plan",
          [](const Workspace& w) { return ReadJsonOrNone(w.plan_json()); },
          "plan.json of pano4d.run, or None")
      .def(
          "summary",
          [](const Workspace& w, const std::string& stage) {
            if (stage == "sfm") return ReadJsonOrNone(w.sfm_json());
            if (stage == "fit") return ReadJsonOrNone(w.fit_json());
            if (stage == "metrics") return ReadJsonOrNone(w.metrics_json());
            if (stage == "frames") return ReadJsonOrNone(w.frames_json());
            throw Error("summary", "stage", stage,
                        "must be sfm, frames, fit or metrics");
          },
          py::arg("stage"),
          "A stage's summary as a dict (sfm.json, frames.json, fit.json, "
          "metrics.json), or None before the stage ran")
      .def(
          "stamps",
          [](const Workspace& w) {
            py::dict d;
            if (!fs::is_directory(w.stamps())) return d;
            for (const auto& e : fs::directory_iterator(w.stamps())) {
              if (e.path().extension() != ".json") continue;
              d[py::str(e.path().stem().string())] =
                  ToPython(ReadJson(e.path()));
            }
            return d;
          },
          "Per completed stage, the inputs and options it completed with")
      .def(
          "scene",
          [](const Workspace& w) {
            if (!fs::exists(w.checkpoint())) {
              throw Error::In(w.checkpoint().string(),
                              "missing: pano4d.fit writes it");
            }
            return std::make_shared<GaussianScene>(
                ReadCheckpointScene(w.checkpoint()));
          },
          "The fitted scene of the fit's checkpoint")
      .def("__repr__", [](const Workspace& w) {
        return "Workspace('" + w.root().string() + "')";
      });

  m.def(
      "render",
      [](const GaussianScene& scene, RasterCamera camera, int t,
         std::optional<int> width, std::optional<int> height) {
        if (width) {
          camera.cx *= static_cast<float>(*width) / camera.width;
          camera.fx *= static_cast<float>(*width) / camera.width;
          camera.width = *width;
        }
        if (height) {
          camera.cy *= static_cast<float>(*height) / camera.height;
          camera.fy *= static_cast<float>(*height) / camera.height;
          camera.height = *height;
        }
        cv::Mat bgr;
        SceneRenderer renderer(scene);
        {
          py::gil_scoped_release release;
          bgr = renderer.Render(camera, t);
        }
        const RenderOutput& out = renderer.output();
        const py::ssize_t h = out.height, w = out.width;
        py::dict d;
        d["image"] = Rgb8(bgr);
        d["rgb"] = py::array_t<float>({h, w, py::ssize_t{3}}, out.rgb.data());
        d["depth"] = py::array_t<float>({h, w}, out.depth.data());
        d["alpha"] = py::array_t<float>({h, w}, out.alpha.data());
        return d;
      },
      py::arg("scene"), py::arg("camera"), py::arg("t"),
      py::arg("width") = py::none(), py::arg("height") = py::none(),
      "Renders the scene at time t: image (RGB uint8 [H, W, 3], the pixels "
      "`pano4d render` writes), rgb (float, linear), depth (z) and alpha. "
      "width and height rescale the camera's intrinsics.");

  m.def(
      "read_cameras",
      [](const py::object& path) {
        py::list out;
        for (const TimedCamera& c : ReadCameraFile(FsPath(path).string())) {
          py::dict d;
          d["camera"] = c.camera;
          d["t"] = c.time;
          out.append(d);
        }
        return out;
      },
      py::arg("path"),
      "A camera file (`pano4d render --trajectory FILE`'s layout, as "
      "render's cameras.json and trajectories.json): [{'camera', 't'}], read "
      "as `pano4d render` reads it");

  m.def(
      "read_image",
      [](const py::object& path) {
        return Rgb8(ReadImage(FsPath(path)).ToBgr8());
      },
      py::arg("path"),
      "An image file (PNG, JPEG, EXR) as RGB uint8 [H, W, 3], decoded as "
      "pano4d decodes its inputs");

  AddPriorFunctions(m);

  AddStageFunctions(m);
}
