// ICL-NUIM, TUM-compatible release: rgb/ + associations.txt (or rgb.txt) +
// <name>.gt.freiburg whose lines are "index tx ty tz qx qy qz qw" with index =
// frame number (the number in rgb/<n>.png). Default camera has fy < 0.
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

PinholeCameraOptions IclCameraOptions() {
  PinholeCameraOptions o;
  o.width = 640;
  o.height = 480;
  o.fx = 481.20;
  o.fy = -480.00;
  o.flipped_y = true;
  o.cx = 319.5;
  o.cy = 239.5;
  return o;
}

namespace {

bool ParseNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* stop = nullptr;
  *v = std::strtod(s.c_str(), &stop);
  return stop == s.c_str() + s.size() && std::isfinite(*v);
}

// Frame number of rgb/<n>.png; false when the stem is not an integer.
bool FrameNumber(const std::string& path, long* n) {
  const std::string stem = std::filesystem::path(path).stem().string();
  if (stem.empty() || stem.size() > 12) return false;
  for (char c : stem)
    if (c < '0' || c > '9') return false;
  *n = std::stol(stem);
  return true;
}

// Columns of the rgb image in associations.txt ("t path t path", rgb or depth first).
void FindRgbColumns(const std::string& file, int* time_col, int* path_col) {
  const auto lines = ReadDataLines(file);
  if (lines.empty()) throw std::runtime_error(file + ": lists no images");
  const std::vector<std::string> f = SplitFields(lines.front().second, false);
  *time_col = 0;
  *path_col = 1;
  for (size_t j = 1; j < f.size(); j += 2) {
    if (f[j].rfind("rgb", 0) == 0) {
      *time_col = static_cast<int>(j) - 1;
      *path_col = static_cast<int>(j);
      return;
    }
  }
}

}  // namespace

std::unique_ptr<FrameSource> OpenIclDataset(const DatasetOptions& options) {
  namespace fs = std::filesystem;
  const std::string assoc = JoinPath(options.path, "associations.txt");
  const std::string rgb_txt = JoinPath(options.path, "rgb.txt");
  std::vector<ImageEntry> images;
  if (IsFile(assoc)) {
    int tc = 0, pc = 1;
    FindRgbColumns(assoc, &tc, &pc);
    images = ReadImageIndex(assoc, options.path, TimeUnit::kSeconds, false, tc, pc);
  } else if (IsFile(rgb_txt)) {
    images = ReadImageIndex(rgb_txt, options.path);
  } else {
    throw std::runtime_error("ICL-NUIM image index not found: " + assoc + " (nor " + rgb_txt + ")");
  }
  const PinholeCameraOptions cam = ResolveCamera(options, images, [](PinholeCameraOptions* o) {
    *o = IclCameraOptions();
    return true;
  });

  std::vector<std::string> gt_files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(options.path, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 12 && name.compare(name.size() - 12, 12, ".gt.freiburg") == 0) gt_files.push_back(e.path().string());
  }
  if (gt_files.size() > 1) {
    throw std::runtime_error("ICL-NUIM folder " + options.path + " has several *.gt.freiburg files: " +
                             gt_files[0] + ", " + gt_files[1]);
  }
  GroundTruth gt;
  std::vector<std::optional<Se3>> image_gt(images.size());
  if (gt_files.size() == 1) {
    const std::string& file = gt_files[0];
    // Frame number -> image; by file name when every image is rgb/<n>.png,
    // else by position counted from the first ground-truth index.
    std::map<long, size_t> by_number;
    bool numbered = true;
    for (size_t i = 0; i < images.size() && numbered; ++i) {
      long n = 0;
      numbered = FrameNumber(images[i].path, &n) && by_number.emplace(n, i).second;
    }
    long first_index = 0, prev_index = 0;
    int prev_line = 0;
    for (const auto& [line, text] : ReadDataLines(file)) {
      const std::vector<std::string> f = SplitFields(text, false);
      if (f.size() != 8) ThrowAtLine(file, line, "expected 8 fields 'index tx ty tz qx qy qz qw', got " + std::to_string(f.size()));
      double v[8];
      for (int i = 0; i < 8; ++i) {
        if (!ParseNumber(f[i], &v[i])) ThrowAtLine(file, line, "field " + std::to_string(i + 1) + " '" + f[i] + "' is not a number");
      }
      if (v[0] != std::floor(v[0]) || v[0] < 0) ThrowAtLine(file, line, "frame index '" + f[0] + "' is not a non-negative integer");
      const long index = static_cast<long>(v[0]);
      if (prev_line > 0 && index <= prev_index) {
        ThrowAtLine(file, line, "frame index " + f[0] + " is not after the one on line " + std::to_string(prev_line) +
                                    "; indices must be strictly increasing");
      }
      if (prev_line == 0) first_index = index;
      prev_index = index;
      prev_line = line;
      const double qn = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
      if (std::abs(qn - 1.0) > 1e-2) ThrowAtLine(file, line, "quaternion norm " + std::to_string(qn) + " is not 1");
      const Se3 T_wc = Se3::FromTumXyzw(Eigen::Vector3d(v[1], v[2], v[3]), v[4], v[5], v[6], v[7]);
      size_t i = 0;
      if (numbered) {
        const auto it = by_number.find(index);
        if (it == by_number.end()) continue;
        i = it->second;
      } else {
        if (index - first_index >= static_cast<long>(images.size())) continue;
        i = static_cast<size_t>(index - first_index);
      }
      image_gt[i] = T_wc;
    }
    for (size_t i = 0; i < images.size(); ++i)
      if (image_gt[i]) gt.emplace_back(images[i].t, *image_gt[i]);
  } else {
    const std::string tum = JoinPath(options.path, "groundtruth.txt");
    if (IsFile(tum)) {
      gt = ToGroundTruth(ReadTumTrajectory(tum, GroundTruthReadOptions()));
      image_gt = AssociateNearest(images, gt, SecondsToNs(options.max_diff_s));
    }
  }
  return std::make_unique<ListFrameSource>(cam, std::move(images), std::move(gt), std::move(image_gt));
}

}  // namespace rumi
