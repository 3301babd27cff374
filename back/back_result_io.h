#pragma once
// Debug output of rumi-back's file mode until the shared binary submap codec
// (ipc/) exists: a JSON dump per submap, a JSON summary per window, and the
// keyframe trajectory as TUM text (T_wc). Formats are described in docs/back.md.
#include <nlohmann/json.hpp>
#include <string>

#include "back/back_submap_builder.h"

namespace rumi {

nlohmann::json SubmapToJson(const Submap& submap);
nlohmann::json BackResultSummaryJson(const BackResult& result);  // without the submaps

// Writes <dir>/result.json, <dir>/submap_<id>.json, <dir>/submap_<id>_tum.txt.
// Returns false with a message when a file cannot be written.
bool WriteBackResult(const BackResult& result, const std::string& dir, std::string* error);

}  // namespace rumi
