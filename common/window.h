#pragma once
// A sampled image window: what the front's sampler ships to the back (the
// paper's S = S1 u S2 u S3). Images are as captured (distorted); the camera
// carries the distortion so the back can undistort before COLMAP.
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/submap.h"
#include "common/timestamp.h"

namespace rumi {

enum class SampleSet : uint8_t { kS1 = 1, kS2 = 2, kS3 = 3 };

// "1", "2", "3" or "S1".."S3" (either case); false for anything else.
inline bool ParseSampleSet(std::string text, SampleSet* set) {
  if (text.size() == 2 && (text[0] == 'S' || text[0] == 's')) text = text.substr(1);
  if (text != "1" && text != "2" && text != "3") return false;
  *set = static_cast<SampleSet>(text[0] - '0');
  return true;
}

struct WindowFrame {
  Timestamp timestamp = 0;
  cv::Mat image;  // 8-bit grey
  TrackingState front_state = TrackingState::kTracking;
  SampleSet set = SampleSet::kS1;
  int64_t front_submap_id = -1;
};

struct ImageWindow {
  int64_t id = -1;
  PinholeCameraOptions camera;
  std::vector<WindowFrame> frames;  // time order
  // Inside rumi-back only (not encoded): the first frame time of each window
  // its queue joined into this one, so the builder judges each part's
  // coverage on its own (back/window_queue.h).
  std::vector<Timestamp> joined_at;
};

}  // namespace rumi
