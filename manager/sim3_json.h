#pragma once
// The one JSON form of a Sim(3) in rumi's outputs (manager_stats.json
// merge_reports[].S_bf, `rumi query submaps --json`): {"s": scale,
// "q_xyzw": [x, y, z, w], "t": [x, y, z]}, and its reader.
#include <nlohmann/json.hpp>

#include "common/geometry.h"

namespace rumi {

nlohmann::json Sim3ToJson(const Sim3& S);
// Throws nlohmann::json::exception when a key is missing or mistyped.
Sim3 Sim3FromJson(const nlohmann::json& j);

}  // namespace rumi
