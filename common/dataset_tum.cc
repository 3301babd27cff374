// TUM RGB-D: rgb.txt (seconds, path) + groundtruth.txt (TUM, camera -> world).
// The camera comes from the config, else from the folder name (freiburg1/2/3).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

PinholeCameraOptions TumCameraOptions(int freiburg) {
  PinholeCameraOptions o;
  o.width = 640;
  o.height = 480;
  switch (freiburg) {
    case 1:
      o.fx = 517.306408, o.fy = 516.469215, o.cx = 318.643040, o.cy = 255.313989;
      o.k1 = 0.262383, o.k2 = -0.953104, o.p1 = -0.005358, o.p2 = 0.002628, o.k3 = 1.163314;
      return o;
    case 2:
      o.fx = 520.908620, o.fy = 521.007327, o.cx = 325.141442, o.cy = 249.701764;
      o.k1 = 0.231222, o.k2 = -0.784899, o.p1 = -0.003257, o.p2 = -0.000105, o.k3 = 0.917205;
      return o;
    case 3:  // fr3 images are already undistorted
      o.fx = 535.4, o.fy = 539.2, o.cx = 320.1, o.cy = 247.6;
      return o;
  }
  throw std::invalid_argument("TUM camera: no freiburg" + std::to_string(freiburg));
}

int DetectTumFreiburg(const std::string& folder) {
  std::filesystem::path p = std::filesystem::path(folder).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // trailing slash
  std::string name = p.filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  int found = 0;
  for (int n = 1; n <= 3; ++n) {
    const std::string d = std::to_string(n);
    if (name.find("freiburg" + d) != std::string::npos || name.find("fr" + d) != std::string::npos) {
      if (found != 0) return 0;  // ambiguous
      found = n;
    }
  }
  return found;
}

std::unique_ptr<FrameSource> OpenTumDataset(const DatasetOptions& options) {
  std::vector<ImageEntry> images = ReadImageIndex(JoinPath(options.path, "rgb.txt"), options.path);
  const PinholeCameraOptions cam = ResolveCamera(options, images, [&](PinholeCameraOptions* o) {
    const int fr = DetectTumFreiburg(options.path);
    if (fr == 0) {
      throw std::runtime_error("TUM dataset " + options.path +
                               ": cannot tell the camera (freiburg1/2/3, fr1/fr2/fr3) from the folder name; "
                               "give a config with a camera section (configs/tum_fr1.yaml ...)");
    }
    *o = TumCameraOptions(fr);
    return true;
  });
  GroundTruth gt;
  const std::string gt_path = JoinPath(options.path, "groundtruth.txt");
  if (IsFile(gt_path)) gt = ToGroundTruth(ReadTumTrajectory(gt_path, GroundTruthReadOptions()));
  auto image_gt = AssociateNearest(images, gt, SecondsToNs(options.max_diff_s));
  return std::make_unique<ListFrameSource>(cam, std::move(images), std::move(gt), std::move(image_gt));
}

}  // namespace rumi
