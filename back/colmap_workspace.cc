#include "back/colmap_workspace.h"

#include <unistd.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "back/model_to_submap.h"
#include "common/camera.h"
#include "common/logging.h"
#include "common/process/process_info.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

// A workspace in use holds kOwnerFile with its process's identity; one whose
// owner is dead was left by a killed rumi-back (ReclaimStaleWorkspaces).
constexpr const char* kOwnerFile = ".rumi-back-owner";

bool HasDistortion(const PinholeCameraOptions& c) {
  return c.k1 != 0 || c.k2 != 0 || c.p1 != 0 || c.p2 != 0 || c.k3 != 0;
}

// Linear stretch of a low-contrast 8-bit image so that its 0.5 and 99.5
// percentiles span 0..255. Well-exposed frames (spread >= 128) are kept as
// they are; only geometry-free grey levels change, never pixel positions.
cv::Mat StretchContrast(const cv::Mat& img) {
  if (img.type() != CV_8UC1 || img.empty()) return img;
  int hist[256] = {0};
  for (int r = 0; r < img.rows; ++r) {
    const uint8_t* p = img.ptr<uint8_t>(r);
    for (int c = 0; c < img.cols; ++c) ++hist[p[c]];
  }
  const double n = static_cast<double>(img.total());
  int lo = 0, hi = 255;
  for (double acc = 0; lo < 255 && (acc += hist[lo]) < 0.005 * n;) ++lo;
  for (double acc = 0; hi > 0 && (acc += hist[hi]) < 0.005 * n;) --hi;
  if (hi - lo >= 128 || hi <= lo) return img;
  cv::Mat out;
  img.convertTo(out, CV_8U, 255.0 / (hi - lo), -255.0 * lo / (hi - lo));
  return out;
}

bool WritePairs(const fs::path& path, const ImageWindow& window, const std::vector<std::pair<int, int>>& pairs) {
  std::ofstream out(path);
  for (const auto& [i, j] : pairs)
    out << ColmapImageName(window.frames[i].timestamp) << ' ' << ColmapImageName(window.frames[j].timestamp) << '\n';
  out.close();
  return bool(out);
}

}  // namespace

// Unique per process and call.
ColmapWorkspace::ColmapWorkspace(const std::string& root, int64_t window_id, int64_t counter)
    : dir_(fs::path(root) / ("window_" + std::to_string(window_id) + "_" + std::to_string(getpid()) + "_" +
                             std::to_string(counter))) {}

bool ColmapWorkspace::Create(bool keep, std::string* why) {
  std::error_code ec;
  fs::remove_all(dir_, ec);
  fs::create_directories(images(), ec);
  if (ec) {
    *why = "cannot create workspace " + dir_.string() + ": " + ec.message();
    return false;
  }
  const ProcessId me = SelfProcessId();
  std::ofstream(dir_ / kOwnerFile) << me.pid << " " << me.start_ticks << "\n";
  created_ = true;
  keep_ = keep;
  return true;
}

ColmapWorkspace::~ColmapWorkspace() {
  if (!created_) return;
  std::error_code ec;
  if (keep_) {  // kept: released, no owner
    fs::remove(dir_ / kOwnerFile, ec);
    return;
  }
  fs::remove_all(dir_, ec);
  if (ec) spdlog::warn("cannot remove workspace {}: {}", dir_.string(), ec.message());
}

std::vector<std::string> ReclaimStaleWorkspaces(const std::string& root) {
  std::vector<std::string> removed;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    if (!e.is_directory() || e.path().filename().string().rfind("window_", 0) != 0) continue;
    std::ifstream in(e.path() / kOwnerFile);
    ProcessId owner;
    if (!(in >> owner.pid >> owner.start_ticks)) continue;  // kept on purpose, or not ours
    if (ProcessAlive(owner)) continue;
    std::error_code rec;
    fs::remove_all(e.path(), rec);
    if (!rec) {
      spdlog::info("back: removed the workspace {} of a rumi-back that died (pid {})", e.path().string(), owner.pid);
      removed.push_back(e.path().string());
    }
  }
  return removed;
}

bool WriteColmapImages(const ImageWindow& window, const std::vector<bool>& blank, bool normalize_contrast,
                       const ColmapWorkspace& ws, std::unordered_map<Timestamp, cv::Mat>* written, std::string* why) {
  const bool undistort = HasDistortion(window.camera);
  PinholeCamera camera(window.camera);
  for (size_t i = 0; i < window.frames.size(); ++i) {
    if (blank[i]) continue;
    const WindowFrame& f = window.frames[i];
    cv::Mat img = undistort ? camera.UndistortImage(f.image) : f.image;
    if (normalize_contrast) img = StretchContrast(img);
    if (written) (*written)[f.timestamp] = img;
    const fs::path p = ws.images() / ColmapImageName(f.timestamp);
    bool ok = false;
    std::string error;
    try {
      ok = cv::imwrite(p.string(), img);
    } catch (const cv::Exception& e) {
      error = e.what();
    }
    if (!ok) {
      *why = "cannot write " + p.string() + " " + error;
      return false;
    }
  }
  return true;
}

std::vector<std::pair<int, int>> SelectWindowPairs(const ImageWindow& window, const WindowLayout& layout,
                                                   const PairSelectionOptions& options) {
  std::vector<std::pair<int, int>> pairs;
  for (int k = 0; k <= int(layout.stretches.size()); ++k) {
    std::vector<SampleSet> sets;
    std::vector<int> index;  // of the side's frames that are not blank
    for (size_t i = 0; i < window.frames.size(); ++i)
      if (!layout.blank[i] && layout.side[i] == k) sets.push_back(window.frames[i].set), index.push_back(int(i));
    for (const auto& [i, j] : SelectImagePairs(sets, options)) pairs.push_back({index[i], index[j]});
  }
  return pairs;
}

std::vector<std::pair<int, int>> FillPairs(const WindowLayout& layout, const std::vector<std::pair<int, int>>& selected) {
  const std::set<std::pair<int, int>> have(selected.begin(), selected.end());
  const int n = int(layout.blank.size());
  std::vector<std::pair<int, int>> rest;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (!layout.blank[i] && !layout.blank[j] && layout.side[i] == layout.side[j] && !have.count({i, j}))
        rest.push_back({i, j});
  return rest;
}

bool WritePairLists(const std::string& matcher, const ImageWindow& window, const WindowLayout& layout,
                    const PairSelectionOptions& options, const ColmapWorkspace& ws, int* matched_pairs,
                    std::string* why) {
  if (matcher == "exhaustive") {
    const int n = int(window.frames.size()) - layout.num_blank;
    *matched_pairs = n * (n - 1) / 2;
  }
  if (matcher != "pairs") return true;
  const std::vector<std::pair<int, int>> pairs = SelectWindowPairs(window, layout, options);
  if (!WritePairs(ws.pairs(), window, pairs)) {
    *why = "cannot write " + ws.pairs().string();
    return false;
  }
  *matched_pairs = int(pairs.size());
  // The fill's list: without stretches the fill matches every pair (exhaustive_matcher).
  if (!layout.stretches.empty() && !WritePairs(ws.fill_pairs(), window, FillPairs(layout, pairs))) {
    *why = "cannot write " + ws.fill_pairs().string();
    return false;
  }
  return true;
}

}  // namespace rumi
