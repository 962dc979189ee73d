#pragma once

#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace pano4d::testing {

// The entry of `stage` in plan.json's stages; a test failure (and the plan
// itself) when the plan has none.
inline const nlohmann::json& PlanStage(const nlohmann::json& plan,
                                       const std::string& stage) {
  for (const auto& s : plan["stages"])
    if (s["stage"] == stage) return s;
  ADD_FAILURE() << "no stage " << stage << " in " << plan.dump(2);
  return plan;
}

}  // namespace pano4d::testing
