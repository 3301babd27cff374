#pragma once
// Frame sources: dataset readers yield frames in time order with the camera
// model and optional ground truth (camera -> world, T_wc).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera.h"
#include "common/geometry.h"
#include "common/timestamp.h"

namespace rumi {

struct Frame {
  Timestamp timestamp = 0;
  cv::Mat image;                  // 8-bit grey, distorted as captured
  std::optional<Se3> T_wc_gt;     // associated ground truth, if any
  std::string path;               // source file, for messages
};

enum class DatasetKind { kTum, kEuroc, kIcl, kKitti, kFolder };
bool ParseDatasetKind(const std::string& name, DatasetKind* kind);

struct DatasetOptions {
  DatasetKind kind = DatasetKind::kTum;
  std::string path;
  std::string config_path;      // optional rumi config with a camera section
  double max_diff_s = 0.02;     // ground-truth association (TUM convention)
  bool Check(std::string* why = nullptr) const;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual const PinholeCamera& camera() const = 0;
  virtual size_t size() const = 0;  // number of frames listed
  // Next readable frame in time order; false at end. Unreadable/corrupt images
  // are logged and skipped (counted in skipped()).
  virtual bool Next(Frame* frame) = 0;
  virtual void Rewind() = 0;
  // Moves past the next listed frame without reading its image (a replay
  // that is late). False at the end.
  virtual bool Skip();
  virtual size_t skipped() const = 0;
  // All timestamps listed (for tracking-rate denominators).
  virtual const std::vector<Timestamp>& timestamps() const = 0;
  // Ground truth (T_wc) as loaded, possibly denser than the frames; empty if none.
  virtual const std::vector<std::pair<Timestamp, Se3>>& ground_truth() const = 0;
};

// Throws std::runtime_error with a clear message (path + reason) on a missing
// folder/index file, unsorted or duplicate timestamps, malformed lines.
std::unique_ptr<FrameSource> OpenDataset(const DatasetOptions& options);

}  // namespace rumi
