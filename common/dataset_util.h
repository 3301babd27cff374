#pragma once
// Pieces shared by the dataset readers (dataset_<kind>.cc): image index files,
// ground-truth association, calib.txt, camera sections of configs, and the
// FrameSource that serves a sorted list of images.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/text_fields.h"
#include "common/trajectory.h"

namespace rumi {

using GroundTruth = std::vector<std::pair<Timestamp, Se3>>;

struct ImageEntry {
  Timestamp t = 0;
  std::string path;  // joined with the dataset folder
  int line = 0;      // line in the index file, for messages
};

// "<file>:<line>: <why>" as std::runtime_error.
[[noreturn]] void ThrowAtLine(const std::string& file, int line, const std::string& why);
// Throws "<what> not found: <path>" unless path is a regular file / folder.
void RequireFile(const std::string& path, const std::string& what);
void RequireDirectory(const std::string& path, const std::string& what);
bool IsFile(const std::string& path);
bool IsDirectory(const std::string& path);
std::string JoinPath(const std::string& a, const std::string& b);

enum class TimeUnit { kSeconds, kNanoseconds };
// Reads an image index: one image per data line, '#' comments and blank lines
// skipped. Timestamp in column time_col, relative image path in path_col
// (TUM rgb.txt: 0 1; EuRoC data.csv: 0 1 with commas and ns). Throws naming
// file:line on malformed lines, unsorted or duplicate timestamps, and when
// the file is missing or lists no image.
std::vector<ImageEntry> ReadImageIndex(const std::string& file, const std::string& base_dir,
                                       TimeUnit unit = TimeUnit::kSeconds, bool commas = false,
                                       int time_col = 0, int path_col = 1);

GroundTruth ToGroundTruth(const Trajectory& traj);
// How datasets read their ground truth: as evo does, the first of poses with
// equal timestamps counts (logged); unsorted files are still an error.
TrajectoryReadOptions GroundTruthReadOptions();

// Index of the pose nearest to t with |dt| <= max_diff; -1 when none.
long NearestPose(const GroundTruth& gt, Timestamp t, Timestamp max_diff);
// Per image: its nearest ground-truth pose (within max_diff) or nothing.
std::vector<std::optional<Se3>> AssociateNearest(const std::vector<ImageEntry>& images,
                                                 const GroundTruth& gt, Timestamp max_diff);

// calib.txt: either one line "fx fy cx cy [k1 k2 p1 p2 [k3]]" or KITTI's
// "P0: p00 .. p23" projection matrix (fx fy cx cy from it). Sets only the
// intrinsics and distortion (the size comes from the images). Throws with
// file:line when malformed.
void ReadCalibTxt(const std::string& path, PinholeCameraOptions* o);

// Reads the `camera:` section of a rumi config. Returns false when the file
// has no camera section. *has_size tells whether width and height were given.
bool ReadCameraFromConfig(const std::string& config_path, PinholeCameraOptions* o, bool* has_size);

// Size of the first image that loads; throws when none does.
void ProbeImageSize(const std::vector<ImageEntry>& images, PinholeCameraOptions* o);

// Throws "<source>: invalid camera: <why>" when o.Check fails.
void CheckCamera(const PinholeCameraOptions& o, const std::string& source);

// The camera of a dataset: the `camera:` section of options.config_path when
// there is one, else own(o) (the dataset's calibration; returns whether it set
// the image size). The size is read from the first image when nobody set it.
PinholeCameraOptions ResolveCamera(const DatasetOptions& options, const std::vector<ImageEntry>& images,
                                   const std::function<bool(PinholeCameraOptions*)>& own);

// FrameSource over a sorted image list with per-image ground truth.
class ListFrameSource : public FrameSource {
 public:
  ListFrameSource(const PinholeCameraOptions& camera, std::vector<ImageEntry> images,
                  GroundTruth gt, std::vector<std::optional<Se3>> image_gt);
  const PinholeCamera& camera() const override { return camera_; }
  size_t size() const override { return images_.size(); }
  bool Next(Frame* frame) override;
  void Rewind() override { next_ = 0; }
  bool Skip() override { return next_ < images_.size() && ++next_ > 0; }
  size_t skipped() const override { return skipped_; }
  const std::vector<Timestamp>& timestamps() const override { return timestamps_; }
  const GroundTruth& ground_truth() const override { return gt_; }

 private:
  PinholeCamera camera_;
  std::vector<ImageEntry> images_;
  std::vector<Timestamp> timestamps_;
  GroundTruth gt_;
  std::vector<std::optional<Se3>> image_gt_;
  size_t next_ = 0;
  size_t skipped_ = 0;
};

// Readers, one per file (dataset_<kind>.cc).
std::unique_ptr<FrameSource> OpenTumDataset(const DatasetOptions& options);
std::unique_ptr<FrameSource> OpenEurocDataset(const DatasetOptions& options);
std::unique_ptr<FrameSource> OpenIclDataset(const DatasetOptions& options);
std::unique_ptr<FrameSource> OpenKittiDataset(const DatasetOptions& options);
std::unique_ptr<FrameSource> OpenFolderDataset(const DatasetOptions& options);

// Helpers of the readers, public for tests.
// TUM's published calibrations (ROS default distortion model), 640x480.
PinholeCameraOptions TumCameraOptions(int freiburg);
// 1, 2 or 3 from a folder name containing freiburg1 / fr1 / ...; 0 if none.
int DetectTumFreiburg(const std::string& folder);
// EuRoC cam sensor.yaml (with its %YAML:1.0 directive): intrinsics,
// distortion, resolution and T_BS (camera -> body).
void ReadEurocSensorYaml(const std::string& path, PinholeCameraOptions* o, Se3* T_BS);
// ICL-NUIM defaults (fy < 0 as published for the TUM-compatible files).
PinholeCameraOptions IclCameraOptions();

}  // namespace rumi
