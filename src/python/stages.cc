// pano4d.sfm, depth, fit, expand, export, run, evaluate, command and help:
// the stages run the command line's own code in-process
// (cli::CallCommand), so that one parser, one set of checks and one page of
// help serve both, and every error is the binary's message, raised as
// pano4d.Error. They run without the GIL; a fit checks for Ctrl-C after
// every iteration and stops there with its checkpoint written, as SIGUSR1
// stops the binary.
#include <omp.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "src/cli/app.h"
#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/stop_signal.h"
#include "src/core/workspace.h"
#include "src/pipeline/fit.h"
#include "src/pipeline/render.h"
#include "src/python/module.h"

namespace pano4d::python {
namespace {

namespace fs = std::filesystem;
namespace py = pybind11;

// The command line `pano4d COMMAND` with keyword arguments as its flags:
// name=value is --name value (underscores as dashes), a true bool the flag
// alone, a false bool or None nothing, a list or tuple the flag and each
// item, a path its text.
std::vector<std::string> CommandLine(const std::string& command,
                                     const py::kwargs& kwargs) {
  std::vector<std::string> args{command};
  const auto text = [](py::handle v) {
    if (py::hasattr(v, "__fspath__")) return FsPath(v).string();
    return py::str(v).cast<std::string>();
  };
  for (const auto& [key, value] : kwargs) {
    std::string flag = "--" + key.cast<std::string>();
    std::replace(flag.begin() + 2, flag.end(), '_', '-');
    if (value.is_none()) continue;
    if (py::isinstance<py::bool_>(value)) {
      if (value.cast<bool>()) args.push_back(flag);
      continue;
    }
    args.push_back(flag);
    if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
      for (py::handle item : value) args.push_back(text(item));
    } else {
      args.push_back(text(value));
    }
  }
  return args;
}

// The process-wide settings a command's --threads and --quiet change, put
// back when a Python call returns: one call's options do not leak into the
// next.
class GlobalSettingsRestorer {
 public:
  GlobalSettingsRestorer()
      : threads_(omp_get_max_threads()), level_(GetLogLevel()) {}
  ~GlobalSettingsRestorer() {
    omp_set_num_threads(threads_);
    SetLogLevel(level_);
  }

 private:
  int threads_;
  LogLevel level_;
};

// Runs `pano4d COMMAND --flags` without the GIL. A fit's iterations call
// `progress` (when given) with a dict, and look for Ctrl-C: either, or a
// progress callback that returns False or raises, stops the fit at that
// iteration with its checkpoint kept; Ctrl-C and the callback's exception
// are raised once the checkpoint is written. Returns the exit status.
int Call(const std::string& command, const py::kwargs& kwargs,
         const py::object& progress = py::none()) {
  const std::vector<std::string> args = CommandLine(command, kwargs);
  GlobalSettingsRestorer restore;
  ClearStopRequest();
  std::optional<py::error_already_set> raised;
  FitObserverScope scope([&](const FitProgress& p) {
    py::gil_scoped_acquire gil;
    if (raised) return;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (progress.is_none()) return;
      py::dict d;
      d["iteration"] = p.iteration;
      d["iterations"] = p.iterations;
      d["loss"] = p.loss;
      d["train_psnr"] = p.train_psnr;
      d["gaussians"] = p.gaussians;
      const auto opt = [](const std::optional<double>& v) -> py::object {
        return v ? py::object(py::float_(*v)) : py::object(py::none());
      };
      d["val_psnr"] = opt(p.validation.psnr);
      d["val_mpsnr"] = opt(p.validation.mpsnr);
      d["val_upsnr"] = opt(p.validation.upsnr);
      const py::object answer = progress(d);
      if (!answer.is_none() && !answer.cast<bool>()) RequestStop();
    } catch (py::error_already_set& e) {
      raised.emplace(std::move(e));
      RequestStop();
    }
  });
  int status = 0;
  {
    py::gil_scoped_release release;
    status = cli::CallCommand(args);
  }
  ClearStopRequest();
  if (raised) throw std::move(*raised);
  return status;
}

// The stages: each runs its command and returns the summary it wrote.
py::object Stage(const std::string& command, const fs::path& summary,
                 const py::kwargs& kwargs,
                 const py::object& progress = py::none()) {
  const int status = Call(command, kwargs, progress);
  if (status == cli::kExitStopped) {
    py::dict d;
    d["termination"] = "stopped";
    d["exit_status"] = status;
    return d;
  }
  return ReadJsonOrNone(summary);
}

fs::path PathArg(const py::kwargs& kwargs, const char* name) {
  if (!kwargs.contains(name)) {
    throw Error::In(
        std::string("pano4d"),
        std::string("the keyword argument ") + name + " is required");
  }
  return FsPath(kwargs[name]);
}

}  // namespace

void AddStageFunctions(py::module_& m) {
  m.def(
      "help",
      [](const std::string& command) { return cli::CommandHelp(command); },
      py::arg("command") = "",
      "`pano4d COMMAND --help`: the options a stage takes (keyword "
      "arguments with dashes as underscores)");

  m.def(
      "command",
      [](const std::vector<std::string>& args) {
        GlobalSettingsRestorer restore;
        py::gil_scoped_release release;
        return cli::CallCommand(args);
      },
      py::arg("args"),
      "Runs `pano4d ARGS...` in-process; returns its exit status (0, or 75 "
      "when it stopped on request). Errors raise pano4d.Error.");

  m.def(
      "sfm",
      [](py::kwargs kw) {
        return Stage("sfm", Workspace(PathArg(kw, "workspace")).sfm_json(), kw);
      },
      "pano4d sfm: COLMAP poses and points. Returns sfm.json");
  m.def(
      "depth",
      [](py::kwargs kw) {
        return Stage("depth", Workspace(PathArg(kw, "workspace")).frames_json(),
                     kw);
      },
      "pano4d depth: the frames and their depth maps. Returns frames.json");
  m.def(
      "fit",
      [](py::object progress, py::kwargs kw) {
        return Stage("fit", Workspace(PathArg(kw, "workspace")).fit_json(), kw,
                     progress);
      },
      py::arg("progress") = py::none(),
      "pano4d fit: the 4D Gaussians. progress(dict) is called after every "
      "iteration (iteration, iterations, loss, train_psnr, gaussians, "
      "val_psnr, val_mpsnr, val_upsnr); returning False stops the fit there "
      "with its checkpoint kept (resume=True continues it), as Ctrl-C does. "
      "Returns fit.json, or {'termination': 'stopped'}");
  m.def(
      "expand",
      [](py::kwargs kw) {
        return Stage(
            "expand",
            Workspace(PathArg(kw, "workspace")).expand() / "steps.json", kw);
      },
      "pano4d expand: the panoramic expansion of a fitted scene. Returns "
      "its steps.json");
  m.def(
      "export",
      [](py::kwargs kw) {
        const fs::path out =
            kw.contains("out")
                ? PathArg(kw, "out")
                : Workspace(PathArg(kw, "workspace")).export_dir();
        return Stage("export", out / "ply" / kPlySequenceManifest, kw);
      },
      "pano4d export: the PLY per time, scene4d and cameras. Returns the "
      "PLY sequence's manifest");
  m.def(
      "run",
      [](py::kwargs kw) {
        return Stage("run", Workspace(PathArg(kw, "workspace")).plan_json(),
                     kw);
      },
      "pano4d run: every stage the input needs. Returns plan.json");
  m.def(
      "evaluate",
      [](const py::object& dataset, const py::object& renders, py::kwargs kw) {
        kw["dataset"] = dataset;
        kw["renders"] = renders;
        const fs::path out = kw.contains("out")
                                 ? PathArg(kw, "out")
                                 : PathArg(kw, "renders") / "metrics";
        return Stage("eval", out / "metrics.json", kw);
      },
      py::arg("dataset"), py::arg("renders"),
      "pano4d eval: DyCheck's metrics of renders (<frame>.png) against a "
      "dataset split. Returns the metrics.json it writes");
}

}  // namespace pano4d::python
