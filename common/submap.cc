#include "common/submap.h"

namespace rumi {

const char* ToString(TrackingState s) {
  switch (s) {
    case TrackingState::kInitializing: return "initializing";
    case TrackingState::kTracking: return "tracking";
    case TrackingState::kLost: return "lost";
    case TrackingState::kCoarse: return "coarse";
  }
  return "unknown";
}

}  // namespace rumi
