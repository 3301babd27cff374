#include "common/dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

#include "common/dataset_util.h"

namespace rumi {

bool ParseDatasetKind(const std::string& name, DatasetKind* kind) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  if (n == "tum") {
    *kind = DatasetKind::kTum;
  } else if (n == "euroc") {
    *kind = DatasetKind::kEuroc;
  } else if (n == "icl" || n == "icl_nuim" || n == "icl-nuim") {
    *kind = DatasetKind::kIcl;
  } else if (n == "kitti") {
    *kind = DatasetKind::kKitti;
  } else if (n == "folder") {
    *kind = DatasetKind::kFolder;
  } else {
    return false;
  }
  return true;
}

bool DatasetOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (path.empty()) return fail("dataset path is empty");
  if (!std::isfinite(max_diff_s) || max_diff_s <= 0.0 || max_diff_s > 10.0) {
    return fail("max_diff_s must be in (0, 10] seconds, got " + std::to_string(max_diff_s));
  }
  return true;
}

bool FrameSource::Skip() {
  Frame f;
  return Next(&f);
}

std::unique_ptr<FrameSource> OpenDataset(const DatasetOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::runtime_error("dataset options: " + why);
  RequireDirectory(options.path, "dataset folder");
  switch (options.kind) {
    case DatasetKind::kTum:
      return OpenTumDataset(options);
    case DatasetKind::kEuroc:
      return OpenEurocDataset(options);
    case DatasetKind::kIcl:
      return OpenIclDataset(options);
    case DatasetKind::kKitti:
      return OpenKittiDataset(options);
    case DatasetKind::kFolder:
      return OpenFolderDataset(options);
  }
  throw std::runtime_error("unknown dataset kind");
}

}  // namespace rumi
