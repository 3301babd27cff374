// KITTI odometry. Two layouts:
//  - native: image_0/ (or rgb/) with 000000.png.., times.txt, calib.txt with
//    "P0: ..", poses in poses.txt beside them or ../../poses/<seq>.txt (3x4,
//    camera 0 -> first camera 0, one line per frame);
//  - converted: rgb.txt + groundtruth.txt (TUM) + calib.txt.
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

std::unique_ptr<FrameSource> OpenKittiDataset(const DatasetOptions& options) {
  namespace fs = std::filesystem;
  std::vector<ImageEntry> images;
  GroundTruth gt;
  const std::string rgb_txt = JoinPath(options.path, "rgb.txt");
  if (IsFile(rgb_txt)) {
    images = ReadImageIndex(rgb_txt, options.path);
    const std::string gt_path = JoinPath(options.path, "groundtruth.txt");
    if (IsFile(gt_path)) gt = ToGroundTruth(ReadTumTrajectory(gt_path, GroundTruthReadOptions()));
  } else {
    const std::string times_path = JoinPath(options.path, "times.txt");
    RequireFile(times_path, "KITTI times file (or rgb.txt)");
    std::string image_dir = JoinPath(options.path, "image_0");
    if (!IsDirectory(image_dir)) image_dir = JoinPath(options.path, "rgb");
    RequireDirectory(image_dir, "KITTI image folder (image_0/ or rgb/) in " + options.path + ":");
    const std::vector<Timestamp> times = ReadTimestampList(times_path);
    if (times.empty()) throw std::runtime_error(times_path + ": lists no frames");
    images.resize(times.size());
    for (size_t i = 0; i < times.size(); ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06zu.png", i);
      images[i].t = times[i];
      images[i].path = JoinPath(image_dir, name);
      images[i].line = static_cast<int>(i) + 1;
    }
    fs::path seq = fs::path(options.path).lexically_normal();
    if (seq.filename().empty()) seq = seq.parent_path();
    const std::string beside = JoinPath(options.path, "poses.txt");
    const std::string official = (seq.parent_path().parent_path() / "poses" / (seq.filename().string() + ".txt")).string();
    const std::string poses = IsFile(beside) ? beside : (IsFile(official) ? official : "");
    if (!poses.empty()) gt = ToGroundTruth(ReadKittiTrajectory(poses, times_path));
  }
  const PinholeCameraOptions cam = ResolveCamera(options, images, [&](PinholeCameraOptions* o) {
    ReadCalibTxt(JoinPath(options.path, "calib.txt"), o);
    return false;
  });
  auto image_gt = AssociateNearest(images, gt, SecondsToNs(options.max_diff_s));
  return std::make_unique<ListFrameSource>(cam, std::move(images), std::move(gt), std::move(image_gt));
}

}  // namespace rumi
