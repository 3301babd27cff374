// Generic folder: rgb.txt (seconds, path) + optional groundtruth.txt (TUM) +
// camera from the config or calib.txt ("fx fy cx cy [k1 k2 p1 p2 [k3]]").
// Also reads the Event Camera Dataset layout (ECD frames + calib.txt).
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

std::unique_ptr<FrameSource> OpenFolderDataset(const DatasetOptions& options) {
  std::vector<ImageEntry> images = ReadImageIndex(JoinPath(options.path, "rgb.txt"), options.path);
  const PinholeCameraOptions cam = ResolveCamera(options, images, [&](PinholeCameraOptions* o) {
    const std::string calib = JoinPath(options.path, "calib.txt");
    if (!IsFile(calib)) {
      throw std::runtime_error("folder dataset " + options.path + ": no camera: " + calib +
                               " not found and no config with a camera section given");
    }
    ReadCalibTxt(calib, o);
    return false;
  });
  GroundTruth gt;
  const std::string gt_path = JoinPath(options.path, "groundtruth.txt");
  if (IsFile(gt_path)) gt = ToGroundTruth(ReadTumTrajectory(gt_path, GroundTruthReadOptions()));
  auto image_gt = AssociateNearest(images, gt, SecondsToNs(options.max_diff_s));
  return std::make_unique<ListFrameSource>(cam, std::move(images), std::move(gt), std::move(image_gt));
}

}  // namespace rumi
