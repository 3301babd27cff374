#include "common/dataset_util.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "common/camera_config.h"
#include "common/config.h"

namespace rumi {

namespace fs = std::filesystem;

void ThrowAtLine(const std::string& file, int line, const std::string& why) {
  throw std::runtime_error(file + ":" + std::to_string(line) + ": " + why);
}

bool IsFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

bool IsDirectory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

void RequireFile(const std::string& path, const std::string& what) {
  if (!IsFile(path)) throw std::runtime_error(what + " not found: " + path);
}

void RequireDirectory(const std::string& path, const std::string& what) {
  if (!IsDirectory(path)) throw std::runtime_error(what + " not found: " + path);
}

std::string JoinPath(const std::string& a, const std::string& b) {
  if (a.empty() || (!b.empty() && b[0] == '/')) return b;
  return (fs::path(a) / b).string();
}

std::vector<ImageEntry> ReadImageIndex(const std::string& file, const std::string& base_dir,
                                       TimeUnit unit, bool commas, int time_col, int path_col) {
  RequireFile(file, "image index");
  std::vector<ImageEntry> out;
  const int need = std::max(time_col, path_col) + 1;
  for (const auto& [line, text] : ReadDataLines(file)) {
    const std::vector<std::string> f = SplitFields(text, commas);
    if (static_cast<int>(f.size()) < need) {
      ThrowAtLine(file, line, "expected at least " + std::to_string(need) + " fields (timestamp, image path), got " +
                                  std::to_string(f.size()) + ": '" + text + "'");
    }
    ImageEntry e;
    e.line = line;
    const bool ok = unit == TimeUnit::kSeconds ? ParseSecondsToNs(f[time_col], &e.t) : ParseInt64(f[time_col], &e.t);
    if (!ok) {
      ThrowAtLine(file, line, "bad timestamp '" + f[time_col] + "'" +
                                  (unit == TimeUnit::kNanoseconds ? " (expected integer nanoseconds)" : ""));
    }
    e.path = JoinPath(base_dir, f[path_col]);
    if (!out.empty() && e.t <= out.back().t) {
      ThrowAtLine(file, line, "timestamp " + f[time_col] + (e.t == out.back().t ? " duplicates" : " is before") +
                                  " the one on line " + std::to_string(out.back().line) +
                                  "; timestamps must be strictly increasing");
    }
    out.push_back(std::move(e));
  }
  if (out.empty()) throw std::runtime_error(file + ": lists no images");
  return out;
}

TrajectoryReadOptions GroundTruthReadOptions() {
  TrajectoryReadOptions o;
  o.drop_duplicates = true;
  return o;
}

GroundTruth ToGroundTruth(const Trajectory& traj) {
  GroundTruth gt;
  gt.reserve(traj.size());
  for (const StampedPose& p : traj) gt.emplace_back(p.t, p.T_wc);
  return gt;
}

long NearestPose(const GroundTruth& gt, Timestamp t, Timestamp max_diff) {
  const auto it = NearestInTime(gt.begin(), gt.end(), t, [](const std::pair<Timestamp, Se3>& p) { return p.first; });
  if (it == gt.end() || std::abs(it->first - t) > max_diff) return -1;
  return static_cast<long>(it - gt.begin());
}

std::vector<std::optional<Se3>> AssociateNearest(const std::vector<ImageEntry>& images,
                                                 const GroundTruth& gt, Timestamp max_diff) {
  std::vector<std::optional<Se3>> out(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    const long k = NearestPose(gt, images[i].t, max_diff);
    if (k >= 0) out[i] = gt[static_cast<size_t>(k)].second;
  }
  return out;
}

void ReadCalibTxt(const std::string& path, PinholeCameraOptions* o) {
  RequireFile(path, "calibration file");
  const auto lines = ReadDataLines(path);
  if (lines.empty()) throw std::runtime_error(path + ": no calibration line");
  // KITTI odometry: "P0: 12 numbers" (rectified, no distortion).
  for (const auto& [line, text] : lines) {
    if (text.rfind("P0:", 0) != 0) continue;
    const std::vector<std::string> f = SplitFields(text.substr(3), false);
    double p[12];
    if (f.size() != 12) ThrowAtLine(path, line, "P0 needs 12 numbers, got " + std::to_string(f.size()));
    for (int i = 0; i < 12; ++i) {
      if (!ParseFiniteDouble(f[i], &p[i])) ThrowAtLine(path, line, "P0 entry '" + f[i] + "' is not a number");
    }
    o->fx = p[0];
    o->cx = p[2];
    o->fy = p[5];
    o->cy = p[6];
    o->k1 = o->k2 = o->p1 = o->p2 = o->k3 = 0.0;
    return;
  }
  const auto& [line, text] = lines.front();
  const std::vector<std::string> f = SplitFields(text, false);
  if (f.size() != 4 && f.size() != 8 && f.size() != 9) {
    ThrowAtLine(path, line, "expected 'fx fy cx cy [k1 k2 p1 p2 [k3]]' (4, 8 or 9 numbers) or 'P0: ...', got " +
                                std::to_string(f.size()) + " fields");
  }
  double v[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (size_t i = 0; i < f.size(); ++i) {
    if (!ParseFiniteDouble(f[i], &v[i])) ThrowAtLine(path, line, "field " + std::to_string(i + 1) + " '" + f[i] + "' is not a number");
  }
  o->fx = v[0];
  o->fy = v[1];
  o->cx = v[2];
  o->cy = v[3];
  o->k1 = v[4];
  o->k2 = v[5];
  o->p1 = v[6];
  o->p2 = v[7];
  o->k3 = v[8];
}

bool ReadCameraFromConfig(const std::string& config_path, PinholeCameraOptions* o, bool* has_size) {
  ConfigSection root = LoadConfigFile(config_path);
  if (!root.Has("camera")) return false;
  ConfigSection cam = root.Child("camera");
  *has_size = cam.Has("width") && cam.Has("height");
  ReadOptions(cam, o);
  return true;
}

void ProbeImageSize(const std::vector<ImageEntry>& images, PinholeCameraOptions* o) {
  for (const ImageEntry& e : images) {
    const cv::Mat img = cv::imread(e.path, cv::IMREAD_GRAYSCALE);
    if (img.empty()) continue;
    o->width = img.cols;
    o->height = img.rows;
    return;
  }
  throw std::runtime_error("no readable image among the " + std::to_string(images.size()) +
                           " listed (first: " + (images.empty() ? std::string("none") : images.front().path) + ")");
}

void CheckCamera(const PinholeCameraOptions& o, const std::string& source) {
  std::string why;
  if (!o.Check(&why)) throw std::runtime_error(source + ": invalid camera: " + why);
}

PinholeCameraOptions ResolveCamera(const DatasetOptions& options, const std::vector<ImageEntry>& images,
                                   const std::function<bool(PinholeCameraOptions*)>& own) {
  PinholeCameraOptions o;
  bool has_size = false;
  std::string source;
  if (!options.config_path.empty() && ReadCameraFromConfig(options.config_path, &o, &has_size)) {
    source = options.config_path;
  } else {
    has_size = own(&o);
    source = options.path;
  }
  // The images decide: a camera of another size would make the front skip
  // every frame (or track with a wrong principal point), silently.
  PinholeCameraOptions probed = o;
  ProbeImageSize(images, &probed);  // throws when no image is readable
  if (!has_size) {
    o.width = probed.width;
    o.height = probed.height;
  } else if (probed.width != o.width || probed.height != o.height) {
    throw std::runtime_error(source + ": the camera is " + std::to_string(o.width) + "x" + std::to_string(o.height) +
                             " but the images of " + options.path + " are " + std::to_string(probed.width) + "x" +
                             std::to_string(probed.height) + ": use the calibration of this image size");
  }
  CheckCamera(o, source);
  spdlog::info("dataset {}: camera {}x{} fx {} fy {} cx {} cy {} k {} {} p {} {} k3 {} (from {})", options.path,
               o.width, o.height, o.fx, o.fy, o.cx, o.cy, o.k1, o.k2, o.p1, o.p2, o.k3, source);
  return o;
}

ListFrameSource::ListFrameSource(const PinholeCameraOptions& camera, std::vector<ImageEntry> images,
                                 GroundTruth gt, std::vector<std::optional<Se3>> image_gt)
    : camera_(camera), images_(std::move(images)), gt_(std::move(gt)), image_gt_(std::move(image_gt)) {
  image_gt_.resize(images_.size());
  timestamps_.reserve(images_.size());
  for (const ImageEntry& e : images_) timestamps_.push_back(e.t);
}

bool ListFrameSource::Next(Frame* frame) {
  while (next_ < images_.size()) {
    const size_t i = next_++;
    const ImageEntry& e = images_[i];
    cv::Mat img = cv::imread(e.path, cv::IMREAD_GRAYSCALE);
    if (img.empty()) {
      ++skipped_;
      spdlog::warn("dataset: skipping unreadable image {} (t={})", e.path, FormatSeconds(e.t));
      continue;
    }
    if (img.cols != camera_.width() || img.rows != camera_.height()) {
      ++skipped_;
      spdlog::warn("dataset: skipping {}: {}x{} but the camera is {}x{}", e.path, img.cols, img.rows,
                   camera_.width(), camera_.height());
      continue;
    }
    frame->timestamp = e.t;
    frame->image = std::move(img);
    frame->T_wc_gt = image_gt_[i];
    frame->path = e.path;
    return true;
  }
  return false;
}

}  // namespace rumi
