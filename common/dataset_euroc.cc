// EuRoC MAV (ASL layout): mav0/cam0/data.csv (ns,filename) + cam0/sensor.yaml
// (intrinsics, radtan distortion, resolution, T_BS). Ground truth is the body
// (IMU) pose; the camera pose is T_w_cam = T_w_body * T_BS.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include "common/dataset_util.h"

namespace rumi {

namespace {

std::vector<double> ReadNumbers(const YAML::Node& node, const std::string& path, const std::string& key) {
  if (!node || !node.IsSequence()) throw std::runtime_error(path + ": key '" + key + "' missing or not a list");
  try {
    return node.as<std::vector<double>>();
  } catch (const YAML::Exception&) {
    throw std::runtime_error(path + ": key '" + key + "' is not a list of numbers");
  }
}

}  // namespace

void ReadEurocSensorYaml(const std::string& path, PinholeCameraOptions* o, Se3* T_BS) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("EuRoC sensor file not found: " + path);
  // OpenCV-style "%YAML:1.0" directive is not YAML 1.2: drop directive lines.
  std::stringstream text;
  std::string line;
  while (std::getline(in, line)) text << (line.rfind('%', 0) == 0 ? "" : line) << '\n';
  YAML::Node root;
  try {
    root = YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ":" + std::to_string(e.mark.line + 1) + ": malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw std::runtime_error(path + ": not a YAML map");
  try {
    if (root["camera_model"] && root["camera_model"].as<std::string>() != "pinhole") {
      throw std::runtime_error(path + ": unsupported camera_model '" + root["camera_model"].as<std::string>() + "'");
    }
    if (root["distortion_model"]) {
      const std::string d = root["distortion_model"].as<std::string>();
      if (d != "radial-tangential" && d != "radtan") {
        throw std::runtime_error(path + ": unsupported distortion_model '" + d + "'");
      }
    }
  } catch (const YAML::Exception&) {
    throw std::runtime_error(path + ": camera_model / distortion_model must be strings");
  }
  const std::vector<double> res = ReadNumbers(root["resolution"], path, "resolution");
  const std::vector<double> k = ReadNumbers(root["intrinsics"], path, "intrinsics");
  const std::vector<double> d = ReadNumbers(root["distortion_coefficients"], path, "distortion_coefficients");
  if (res.size() != 2) throw std::runtime_error(path + ": resolution needs 2 numbers [width, height]");
  if (k.size() != 4) throw std::runtime_error(path + ": intrinsics needs 4 numbers [fu, fv, cu, cv]");
  if (d.size() != 4 && d.size() != 5) throw std::runtime_error(path + ": distortion_coefficients needs 4 or 5 numbers");
  o->width = static_cast<int>(res[0]);
  o->height = static_cast<int>(res[1]);
  o->fx = k[0], o->fy = k[1], o->cx = k[2], o->cy = k[3];
  o->k1 = d[0], o->k2 = d[1], o->p1 = d[2], o->p2 = d[3];
  o->k3 = d.size() == 5 ? d[4] : 0.0;
  if (!root["T_BS"] || !root["T_BS"].IsMap()) throw std::runtime_error(path + ": key 'T_BS' missing");
  const std::vector<double> t = ReadNumbers(root["T_BS"]["data"], path, "T_BS.data");
  if (t.size() != 16) throw std::runtime_error(path + ": T_BS.data needs 16 numbers (4x4 row-major)");
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T(r, c) = t[4 * r + c];
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() <= 0) {
    throw std::runtime_error(path + ": T_BS rotation block is not a rotation");
  }
  *T_BS = Se3::FromMatrix(T);
}

std::unique_ptr<FrameSource> OpenEurocDataset(const DatasetOptions& options) {
  namespace fs = std::filesystem;
  std::string mav = JoinPath(options.path, "mav0");
  std::string seq = options.path;
  if (!IsDirectory(mav)) {
    fs::path p = fs::path(options.path).lexically_normal();
    if (p.filename().empty()) p = p.parent_path();
    if (p.filename() != "mav0") throw std::runtime_error("EuRoC folder not found: " + mav);
    mav = p.string();
    seq = p.parent_path().string();
  }
  const std::string cam_dir = JoinPath(mav, "cam0");
  std::vector<ImageEntry> images =
      ReadImageIndex(JoinPath(cam_dir, "data.csv"), JoinPath(cam_dir, "data"), TimeUnit::kNanoseconds, true);
  PinholeCameraOptions sensor;
  Se3 T_BS;
  ReadEurocSensorYaml(JoinPath(cam_dir, "sensor.yaml"), &sensor, &T_BS);
  const PinholeCameraOptions cam = ResolveCamera(options, images, [&](PinholeCameraOptions* o) {
    *o = sensor;
    return true;
  });

  // Ground truth: native csv (body), else TUM files beside mav0 (camera or body).
  GroundTruth gt;
  const std::string csv = JoinPath(mav, "state_groundtruth_estimate0/data.csv");
  const std::string tum_cam = JoinPath(seq, "groundtruth.txt");
  const std::string tum_body = JoinPath(seq, "groundtruth_body.txt");
  if (IsFile(csv) || (IsFile(tum_body) && !IsFile(tum_cam))) {
    const bool native = IsFile(csv);
    gt = ToGroundTruth(native ? ReadEurocTrajectory(csv, GroundTruthReadOptions())
                              : ReadTumTrajectory(tum_body, GroundTruthReadOptions()));
    for (auto& [t, T_wb] : gt) T_wb = T_wb * T_BS;
    spdlog::debug("EuRoC: body ground truth from {} moved to cam0 by T_BS", native ? csv : tum_body);
  } else if (IsFile(tum_cam)) {
    gt = ToGroundTruth(ReadTumTrajectory(tum_cam, GroundTruthReadOptions()));
  }
  auto image_gt = AssociateNearest(images, gt, SecondsToNs(options.max_diff_s));
  return std::make_unique<ListFrameSource>(cam, std::move(images), std::move(gt), std::move(image_gt));
}

}  // namespace rumi
