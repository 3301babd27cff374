#pragma once
// A window's COLMAP workspace, <root>/window_<id>_<pid>_<n>/: what COLMAP
// reads (images/, the pair lists) and writes (database<tag>.db,
// sparse<tag>[_all]/, colmap.log). The folder is this process's while it
// builds (an owner file): ReclaimStaleWorkspaces removes those whose
// rumi-back died.
#include <filesystem>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "back/pair_selection.h"
#include "back/window_layout.h"
#include "common/window.h"

namespace rumi {

class ColmapWorkspace {
 public:
  // Names only: nothing is created before Create.
  ColmapWorkspace(const std::string& root, int64_t window_id, int64_t counter);
  // Removes the folder Create made, or (keep) only its owner file.
  ~ColmapWorkspace();
  ColmapWorkspace(const ColmapWorkspace&) = delete;
  ColmapWorkspace& operator=(const ColmapWorkspace&) = delete;

  // Replaces the folder by an empty one with images/ and marks it as this
  // process's. False with why when it cannot be made (nothing to remove then).
  bool Create(bool keep, std::string* why);

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path images() const { return dir_ / "images"; }
  std::filesystem::path log() const { return dir_ / "colmap.log"; }
  std::filesystem::path pairs() const { return dir_ / "pairs.txt"; }
  std::filesystem::path fill_pairs() const { return dir_ / "pairs_fill.txt"; }
  // An attempt's database and model folder ("" = the first attempt, "_retry"; a fill's models go to sparse<tag>_all).
  std::filesystem::path database(const std::string& tag) const { return dir_ / ("database" + tag + ".db"); }
  std::filesystem::path sparse(const std::string& tag, bool fill) const {
    return dir_ / ("sparse" + tag + (fill ? "_all" : ""));
  }

 private:
  std::filesystem::path dir_;
  bool created_ = false;
  bool keep_ = false;
};

// Removes the workspaces under root whose rumi-back died (kill -9 leaves
// 10-11 MB per window). Returns the folders removed.
std::vector<std::string> ReclaimStaleWorkspaces(const std::string& root);

// Writes the frames that are not blank into images/, undistorted (when the
// camera has distortion) and, with normalize_contrast, stretched, named by
// timestamp (ColmapImageName: name order = time order). With `written`,
// keeps each image written by timestamp (the ORB keypoints are detected on
// them). False with why on the first image not written.
bool WriteColmapImages(const ImageWindow& window, const std::vector<bool>& blank, bool normalize_contrast,
                       const ColmapWorkspace& ws, std::unordered_map<Timestamp, cv::Mat>* written, std::string* why);

// The image pairs matcher "pairs" has COLMAP match, as frame indices (i < j).
// No pair crosses a blank stretch: the back does not vouch for a link there
// (blank_cut.h), and a model joined across one bends both sides (generated
// `kidnap` seed 3: a side of 12 frames at 0.055 m out of the fill's joint
// model, 0.0018 m alone). So the selection runs per side, and the fill
// matches the other pairs within each side.
std::vector<std::pair<int, int>> SelectWindowPairs(const ImageWindow& window, const WindowLayout& layout,
                                                   const PairSelectionOptions& options);
// Every pair of frames on one side, neither blank, that `selected` lacks.
std::vector<std::pair<int, int>> FillPairs(const WindowLayout& layout, const std::vector<std::pair<int, int>>& selected);

// Writes the pair lists COLMAP's matches_importer reads for `matcher`
// ("pairs": pairs.txt, and pairs_fill.txt when there are blank stretches;
// other matchers need none) and sets *matched_pairs to the pairs matched per
// attempt (sequential: 0, COLMAP picks). False with why.
bool WritePairLists(const std::string& matcher, const ImageWindow& window, const WindowLayout& layout,
                    const PairSelectionOptions& options, const ColmapWorkspace& ws, int* matched_pairs,
                    std::string* why);

}  // namespace rumi
