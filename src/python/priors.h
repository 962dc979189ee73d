#pragma once
// What the module's files share (module.cc, priors.cc).

#include <pybind11/pybind11.h>

#include "src/core/json.h"

namespace pano4d::python {

// nlohmann::json as Python's dict, list, str, int, float, bool or None.
pybind11::object ToPython(const Json& j);

// scan_priors, read_priors and the write_* functions (priors.cc).
void AddPriorFunctions(pybind11::module_& m);

}  // namespace pano4d::python
