#pragma once
// What the Python module's files share: module.cc (the module, workspaces,
// scenes, renders), stages.cc (the stages), priors.cc (learned priors).

#include <filesystem>

#include <pybind11/pybind11.h>

#include "src/core/json.h"

namespace pano4d::python {

// nlohmann::json as Python's dict, list, str, int, float, bool or None.
pybind11::object ToPython(const Json& j);
// A str or os.PathLike as a path (os.fspath).
std::filesystem::path FsPath(pybind11::handle path);
// The JSON file at `path` as ToPython gives it; None when there is none.
pybind11::object ReadJsonOrNone(const std::filesystem::path& path);

// The stages (stages.cc) and the learned priors' readers and writers
// (priors.cc), added to the module.
void AddStageFunctions(pybind11::module_& m);
void AddPriorFunctions(pybind11::module_& m);

}  // namespace pano4d::python
