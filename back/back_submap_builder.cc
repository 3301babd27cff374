#include "back/back_submap_builder.h"

#include <unistd.h>

#include <algorithm>
#include <limits>
#include <chrono>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <unordered_map>
#include <set>
#include <unordered_set>

#include "back/blank_cut.h"
#include "common/pose_jumps.h"
#include "back/colmap_database.h"
#include "back/keyframe_orb.h"
#include "back/pair_selection.h"
#include "common/camera.h"
#include "common/process/process_info.h"
#include "common/process/subprocess.h"
#include "common/logging.h"

namespace fs = std::filesystem;

namespace rumi {

const char* ToString(BackStatus s) {
  switch (s) {
    case BackStatus::kOk: return "ok";
    case BackStatus::kInvalidWindow: return "invalid_window";
    case BackStatus::kNoModel: return "no_model";
    case BackStatus::kColmapFailed: return "colmap_failed";
    case BackStatus::kTimeout: return "timeout";
    case BackStatus::kCancelled: return "cancelled";
    case BackStatus::kIoError: return "io_error";
    case BackStatus::kModelError: return "model_error";
  }
  return "unknown";
}

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

bool HasDistortion(const PinholeCameraOptions& c) {
  return c.k1 != 0 || c.k2 != 0 || c.p1 != 0 || c.p2 != 0 || c.k3 != 0;
}

// Checks what COLMAP and the conversion rely on; "" when fine.
std::string ValidateWindow(const ImageWindow& w, int min_frames) {
  const PinholeCameraOptions& c = w.camera;
  std::string why;
  if (!c.Check(&why)) return "camera: " + why;
  if (!(c.fx > 0 && c.fy > 0))
    return "camera focal lengths must be positive for COLMAP (fx=" + Num(c.fx) + ", fy=" + Num(c.fy) + ")";
  if (static_cast<int>(w.frames.size()) < min_frames)
    return "window has " + std::to_string(w.frames.size()) + " frames, fewer than " +
           std::to_string(min_frames);
  for (size_t i = 0; i < w.frames.size(); ++i) {
    const WindowFrame& f = w.frames[i];
    if (f.timestamp < 0) return "frame " + std::to_string(i) + " has a negative timestamp";
    if (i > 0 && f.timestamp <= w.frames[i - 1].timestamp)
      return "timestamps not strictly increasing at frame " + std::to_string(i);
    if (f.image.empty()) return "frame " + std::to_string(i) + " has no image";
    if (f.image.depth() != CV_8U || (f.image.channels() != 1 && f.image.channels() != 3))
      return "frame " + std::to_string(i) + " is not an 8-bit grey or BGR image";
    if (f.image.cols != c.width || f.image.rows != c.height)
      return "frame " + std::to_string(i) + " is " + std::to_string(f.image.cols) + "x" +
             std::to_string(f.image.rows) + ", camera is " + std::to_string(c.width) + "x" +
             std::to_string(c.height);
  }
  return "";
}

// Numbered model folders (sparse/0, sparse/1, ...) in numeric order.
std::vector<fs::path> ModelFolders(const fs::path& sparse) {
  std::vector<std::pair<long, fs::path>> found;
  std::error_code ec;
  for (fs::directory_iterator it(sparse, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (it->is_directory() && !n.empty() && std::all_of(n.begin(), n.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; }))
      found.emplace_back(std::stol(n), it->path());
  }
  std::sort(found.begin(), found.end());
  std::vector<fs::path> out;
  for (auto& f : found) out.push_back(f.second);
  return out;
}

// A workspace in use holds kOwnerFile with its process's identity; one whose
// owner is dead was left by a killed rumi-back (ReclaimStaleWorkspaces).
constexpr const char* kOwnerFile = ".rumi-back-owner";

// Removes the workspace unless asked to keep it (a kept one is released: no owner).
class WorkspaceGuard {
 public:
  WorkspaceGuard(fs::path dir, bool keep) : dir_(std::move(dir)), keep_(keep) {
    const ProcessId me = SelfProcessId();
    std::ofstream(dir_ / kOwnerFile) << me.pid << " " << me.start_ticks << "\n";
  }
  ~WorkspaceGuard() {
    if (dir_.empty()) return;
    std::error_code ec;
    if (keep_) {
      fs::remove(dir_ / kOwnerFile, ec);
      return;
    }
    fs::remove_all(dir_, ec);
    if (ec) spdlog::warn("cannot remove workspace {}: {}", dir_.string(), ec.message());
  }

 private:
  fs::path dir_;
  bool keep_;
};

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

}  // namespace

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

BackSubmapBuilder::BackSubmapBuilder(const BackOptions& options, int64_t first_submap_id)
    : options_(options), next_submap_id_(first_submap_id) {}

BackResult BackSubmapBuilder::Build(const ImageWindow& window, const std::atomic<bool>* cancel) {
  const auto t_start = Clock::now();
  BackResult res;
  res.window_id = window.id;
  res.num_frames = static_cast<int>(window.frames.size());
  auto finish = [&](BackStatus s, std::string msg) -> BackResult {
    res.status = s;
    res.message = std::move(msg);
    res.times.total_s = Since(t_start);
    if (s == BackStatus::kOk)
      spdlog::info("window {}: {} submap(s), {}/{} frames registered in {:.1f} s", res.window_id,
                   res.submaps.size(), res.num_registered, res.num_frames, res.times.total_s);
    else
      spdlog::warn("window {}: {}: {}", res.window_id, ToString(s), res.message);
    return res;
  };

  std::string why;
  if (!options_.Check(&why)) return finish(BackStatus::kInvalidWindow, "back options: " + why);
  why = ValidateWindow(window, options_.min_registered_images);
  if (!why.empty()) return finish(BackStatus::kInvalidWindow, why);

  // Per-window workspace: unique per process and call, removed on every exit path.
  const fs::path ws = fs::path(options_.WorkspaceRoot()) /
                      ("window_" + std::to_string(window.id) + "_" + std::to_string(getpid()) +
                       "_" + std::to_string(workspace_counter_++));
  const fs::path images = ws / "images", log = ws / "colmap.log";
  std::error_code ec;
  fs::remove_all(ws, ec);
  fs::create_directories(images, ec);
  if (ec) return finish(BackStatus::kIoError, "cannot create workspace " + ws.string() + ": " + ec.message());
  WorkspaceGuard guard(ws, options_.keep_workspaces);
  if (options_.keep_workspaces) res.workspace = ws.string();

  // Blank frames (a covered lens) show only noise: COLMAP gets none of them
  // (contrast-stretched noise gave SIFT ~330 keypoints per frame to match,
  // for nothing), a model is not short of them, and they cut models (step 9).
  std::vector<bool> blank(window.frames.size(), false);
  if (options_.blank_max_stddev > 0)
    for (size_t i = 0; i < window.frames.size(); ++i)
      blank[i] = IsBlankImage(window.frames[i].image, options_.blank_max_stddev, options_.blank_max_structure);
  const int num_blank = int(std::count(blank.begin(), blank.end(), true));
  if (res.num_frames - num_blank < options_.min_registered_images)
    return finish(BackStatus::kNoModel, std::to_string(num_blank) + " of the window's " +
                                            std::to_string(res.num_frames) +
                                            " frames are blank (the camera saw nothing): too few left to map");
  if (num_blank > 0) spdlog::info("window {}: {} blank frames left out", window.id, num_blank);
  std::vector<std::pair<Timestamp, Timestamp>> stretches;  // where models are cut (step 9)
  {
    std::vector<Timestamp> times;
    for (const WindowFrame& f : window.frames) times.push_back(f.timestamp);
    stretches = BlankStretches(times, blank, options_.blank_min_frames);
  }

  // Undistorted images named by timestamp: name order = time order.
  auto t0 = Clock::now();
  std::unordered_map<Timestamp, cv::Mat> colmap_images;  // for the ORB keypoints
  {
    const bool undistort = HasDistortion(window.camera);
    PinholeCamera camera(window.camera);
    for (size_t i = 0; i < window.frames.size(); ++i) {
      if (blank[i]) continue;
      const WindowFrame& f = window.frames[i];
      cv::Mat img = undistort ? camera.UndistortImage(f.image) : f.image;
      if (options_.normalize_contrast) img = StretchContrast(img);
      if (options_.orb_features > 0) colmap_images[f.timestamp] = img;
      const fs::path p = images / ColmapImageName(f.timestamp);
      bool written = false;
      try {
        written = cv::imwrite(p.string(), img);
      } catch (const cv::Exception& e) {
        why = e.what();
      }
      if (!written) return finish(BackStatus::kIoError, "cannot write " + p.string() + " " + why);
    }
  }
  res.times.undistort_write_s = Since(t0);

  // The image pairs to match (matcher "pairs"), by name, for matches_importer.
  // With matcher "pairs" no pair crosses a blank stretch: the back does not
  // vouch for a link there (step 9), and a model joined across one bends
  // both sides (generated `kidnap` seed 3: a side of 12 frames at 0.055 m
  // out of the fill's joint model, 0.0018 m alone). The selection runs per
  // side, and the fill matches the other pairs within each side.
  std::vector<int> side(window.frames.size(), 0);
  for (size_t i = 0; i < window.frames.size(); ++i)
    for (const auto& st : stretches) side[i] += window.frames[i].timestamp > st.second;
  const auto write_pairs = [&](const fs::path& path, const std::vector<std::pair<int, int>>& pairs) {
    std::ofstream out(path);
    for (const auto& [i, j] : pairs)
      out << ColmapImageName(window.frames[i].timestamp) << ' ' << ColmapImageName(window.frames[j].timestamp) << '\n';
    out.close();
    return bool(out);
  };
  const fs::path pair_list = ws / "pairs.txt", fill_list = ws / "pairs_fill.txt";
  if (options_.matcher == "pairs") {
    std::vector<std::pair<int, int>> pairs;
    for (int k = 0; k <= int(stretches.size()); ++k) {
      std::vector<SampleSet> sets;
      std::vector<int> index;  // of the side's frames that are not blank
      for (size_t i = 0; i < window.frames.size(); ++i)
        if (!blank[i] && side[i] == k) sets.push_back(window.frames[i].set), index.push_back(int(i));
      for (const auto& [i, j] : SelectImagePairs(sets, options_.pairs)) pairs.push_back({index[i], index[j]});
    }
    if (!write_pairs(pair_list, pairs)) return finish(BackStatus::kIoError, "cannot write " + pair_list.string());
    res.matched_pairs = int(pairs.size());
    if (!stretches.empty()) {
      std::set<std::pair<int, int>> have(pairs.begin(), pairs.end());
      std::vector<std::pair<int, int>> rest;
      for (int i = 0; i < res.num_frames; ++i)
        for (int j = i + 1; j < res.num_frames; ++j)
          if (!blank[i] && !blank[j] && side[i] == side[j] && !have.count({i, j})) rest.push_back({i, j});
      if (!write_pairs(fill_list, rest)) return finish(BackStatus::kIoError, "cannot write " + fill_list.string());
    }
  } else if (options_.matcher == "exhaustive") {
    const int n = res.num_frames - num_blank;
    res.matched_pairs = n * (n - 1) / 2;
  }

  const std::string threads = std::to_string(options_.num_threads);
  const PinholeCameraOptions& c = window.camera;
  // COLMAP puts the top-left pixel's centre at (0.5, 0.5): shift cx, cy.
  const std::string params = Num(c.fx) + "," + Num(c.fy) + "," + Num(c.cx + kColmapPixelOffset) +
                             "," + Num(c.cy + kColmapPixelOffset);
  const int first_octave =
      window.camera.width < options_.sift_upsample_below_width ? -1 : options_.sift_first_octave;
  struct Built {
    Submap submap;
    BackSubmapStats stats;
  };
  struct Attempt {
    BackStatus status = BackStatus::kOk;
    std::string message;
    std::vector<Built> built;  // largest first
    std::vector<std::string> warnings;
    size_t models = 0;
    std::string name;  // for the log: "first attempt", "fill", "retry", "fill of the retry"
    int largest() const { return built.empty() ? 0 : built.front().stats.registered_images; }
  };
  // Extraction, matching, mapping and conversion with one SIFT peak
  // threshold, in its own database and model folder. With `fill`, the
  // database of attempt `tag` is reused: no extraction, the pairs the
  // selection left out are matched (COLMAP skips pairs already matched),
  // and the mapper runs again into its own folder.
  auto run_attempt = [&](double peak_threshold, const std::string& tag, bool fill = false) {
    Attempt at;
    const fs::path db = ws / ("database" + tag + ".db"), sparse = ws / ("sparse" + tag + (fill ? "_all" : ""));
    fs::create_directories(sparse, ec);
    if (ec) {
      at.status = BackStatus::kIoError;
      at.message = "cannot create " + sparse.string() + ": " + ec.message();
      return at;
    }
    struct Step {
      const char* name;
      std::vector<std::string> args;
      double* seconds;
      double* cpu_seconds;
    };
    std::vector<Step> steps;
    if (!fill) steps.push_back({"feature_extraction",
                     {"feature_extractor", "--database_path", db.string(), "--image_path",
                      images.string(), "--ImageReader.camera_model", "PINHOLE",
                      "--ImageReader.single_camera", "1", "--ImageReader.camera_params", params,
                      "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", threads,
                      "--SiftExtraction.max_num_features", std::to_string(options_.max_num_features),
                      "--SiftExtraction.first_octave", std::to_string(first_octave)},
                     &res.times.feature_extraction_s, &res.times.feature_extraction_cpu_s});
    if (!fill && peak_threshold > 0)
      steps.back().args.insert(steps.back().args.end(), {"--SiftExtraction.peak_threshold", Num(peak_threshold)});
    if (!fill && options_.sift_domain_size_pooling)
      steps.back().args.insert(steps.back().args.end(), {"--SiftExtraction.domain_size_pooling", "1"});
    if (options_.matcher == "sequential") {
      steps.push_back({"matching",
                       {"sequential_matcher", "--database_path", db.string(),
                        "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads,
                        "--SequentialMatching.overlap", std::to_string(options_.sequential_overlap)},
                       &res.times.matching_s, &res.times.matching_cpu_s});
    } else if (options_.matcher == "pairs" && (!fill || !stretches.empty())) {
      steps.push_back({"matching",
                       {"matches_importer", "--database_path", db.string(), "--match_list_path",
                        (fill ? fill_list : pair_list).string(), "--match_type", "pairs",
                        "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads},
                       &res.times.matching_s, &res.times.matching_cpu_s});
    } else {
      steps.push_back({"matching",
                       {"exhaustive_matcher", "--database_path", db.string(),
                        "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads},
                       &res.times.matching_s, &res.times.matching_cpu_s});
    }
    steps.push_back({"mapping",
                     {"mapper", "--database_path", db.string(), "--image_path", images.string(),
                      "--output_path", sparse.string(), "--Mapper.num_threads", threads,
                      "--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point",
                      "0", "--Mapper.ba_refine_extra_params", "0", "--Mapper.min_model_size",
                      std::to_string(options_.mapper_min_model_size)},
                     &res.times.mapping_s, &res.times.mapping_cpu_s});

    for (Step& step : steps) {
      RunRequest req;
      req.argv.push_back(options_.colmap_path);
      req.argv.insert(req.argv.end(), step.args.begin(), step.args.end());
      req.log_path = log.string();
      // glog would also leave a log file per COLMAP run in /tmp, forever.
      req.env = {"GLOG_logtostderr=1"};
      req.timeout_s = options_.step_timeout_s;
      req.low_priority = options_.low_priority;
      req.cancel = cancel;
      spdlog::debug("window {}: colmap {}", window.id, step.args[0]);
      if (on_stage_) on_stage_(step.args[0]);
      const RunResult r = RunProcess(req);
      *step.seconds += r.seconds;  // a retry adds to the first attempt's time
      *step.cpu_seconds += r.cpu_seconds;
      if (r.status != RunStatus::kOk) {
        at.message = std::string(step.name) + ": " + r.message;
        switch (r.status) {
          case RunStatus::kTimeout: at.status = BackStatus::kTimeout; break;
          case RunStatus::kCancelled: at.status = BackStatus::kCancelled; break;
          default: at.status = BackStatus::kColmapFailed; break;
        }
        return at;
      }
    }

    // Every model folder -> one submap; the largest first.
    const auto t_read = Clock::now();
    const std::vector<fs::path> models = ModelFolders(sparse);
    at.models = models.size();
    for (const fs::path& dir : models) {
      ColmapModel model;
      Built b;
      if (!ReadColmapModelBinary(dir.string(), &model, &why) ||
          !ColmapModelToSubmap(model, -1, &b.submap, &b.stats, &why)) {
        at.status = BackStatus::kModelError;
        at.message = dir.string() + ": " + why;
        return at;
      }
      // The intrinsics were fixed: a change means the flags or the shift are wrong.
      const CameraIntrinsics& k = b.submap.camera;
      if (std::abs(k.fx - c.fx) > 1e-6 * c.fx || std::abs(k.fy - c.fy) > 1e-6 * c.fy ||
          std::abs(k.cx - c.cx) > 1e-6 || std::abs(k.cy - c.cy) > 1e-6 || k.width != c.width ||
          k.height != c.height) {
        at.status = BackStatus::kModelError;
        at.message = dir.string() + ": COLMAP changed the fixed intrinsics";
        return at;
      }
      const std::vector<size_t> jumps = PoseJumps(b.submap, options_.pose_jump_ratio);
      if (!jumps.empty()) {
        std::string which;
        for (size_t i : jumps) which += (which.empty() ? "" : ", ") + FormatSeconds(b.submap.keyframes[i].timestamp);
        at.warnings.push_back(sparse.filename().string() + "/" + dir.filename().string() + ": " +
                              std::to_string(jumps.size()) + " frame(s) registered off the camera path, left out: " +
                              which);
        b.stats.registered_images -= DropKeyframesAt(&b.submap, jumps);
      }
      const int completed = CompleteTracks(&b.submap, options_.track_completion_px);
      const int weak = DropWeakPoints(&b.submap, options_.min_point_observations);
      spdlog::info("back: {}: {} observations added by track completion, {} weak points dropped",
                   dir.filename().string(), completed, weak);
      b.stats.num_points = static_cast<int>(b.submap.points.size());
      if (b.stats.registered_images < options_.min_registered_images) {
        at.warnings.push_back(sparse.filename().string() + "/" + dir.filename().string() + ": dropped, " +
                              std::to_string(b.stats.registered_images) + " registered images");
        continue;
      }
      at.built.push_back(std::move(b));
    }
    std::stable_sort(at.built.begin(), at.built.end(), [](const Built& x, const Built& y) {
      return x.stats.registered_images > y.stats.registered_images;
    });
    res.times.read_convert_s += Since(t_read);
    return at;
  };

  Attempt at = run_attempt(options_.sift_peak_threshold, "");
  if (at.status != BackStatus::kOk) return finish(at.status, at.message);
  at.name = "first attempt";
  std::vector<Attempt> tried;  // with blank stretches: every attempt that built, in order (each side picks one)
  if (!stretches.empty()) tried.push_back(at);
  const int frames = res.num_frames - num_blank;  // that COLMAP saw
  // Whether a part of the window misses too many frames: the model holding
  // most of that part's frames holds less than retry_below_registered of
  // them. A window the queue joined from several (window.joined_at) has one
  // part per window, as each loss gives COLMAP its own model, and so has each
  // side of a blank stretch, where models are cut anyway; otherwise the
  // window is one part and this is its largest model.
  std::vector<Timestamp> part_bounds = window.joined_at;
  for (const auto& st : stretches) part_bounds.push_back(st.second + 1);
  std::sort(part_bounds.begin(), part_bounds.end());
  const auto short_of_frames = [&](const Attempt& a) {
    std::vector<Timestamp> bounds = part_bounds;
    bounds.push_back(std::numeric_limits<Timestamp>::max());
    Timestamp from = std::numeric_limits<Timestamp>::min();
    for (const Timestamp to : bounds) {
      int n = 0, best = 0;
      for (size_t i = 0; i < window.frames.size(); ++i)
        n += !blank[i] && window.frames[i].timestamp >= from && window.frames[i].timestamp < to;
      for (const Built& b : a.built) {
        int in = 0;
        for (const Keyframe& k : b.submap.keyframes) in += k.timestamp >= from && k.timestamp < to;
        best = std::max(best, in);
      }
      if (n > 0 && best < options_.retry_below_registered * n) return true;
      from = to;
    }
    return false;
  };
  // A further attempt replaces `at` when its largest model is larger.
  auto adopt_if_larger = [&](Attempt next, const std::string& failed, const std::string& before, bool* kept) {
    if (next.status != BackStatus::kOk) {
      res.warnings.push_back(failed + next.message);
      return;
    }
    if (!stretches.empty()) tried.push_back(next);
    if (next.largest() > at.largest()) {
      res.warnings.push_back(before + std::to_string(at.largest()) + " frames in the largest model");
      at = std::move(next);
      *kept = true;
    }
  };
  const bool can_fill = options_.matcher == "pairs" && options_.retry_below_registered > 0;
  const bool can_retry =
      options_.retry_peak_threshold > 0 && options_.retry_peak_threshold != options_.sift_peak_threshold;
  // Selected pairs that leave frames out: every other pair, matched on the
  // features of attempt `tag` (a 53-frame blur window: 28 frames with the
  // selected pairs, 51 after). Only the pairs of the frames left out were
  // not enough: the pairs between frames the model holds give the longer
  // tracks, and so the 3D points, that the others register on (2026-11-28:
  // blur seed 2 38 frames instead of 51, kidnap seed 5 42 instead of 52).
  std::string cancelled;  // the message of a cancelled fill
  auto fill = [&](const std::string& tag, double peak_threshold) {
    spdlog::info("window {}: {}/{} frames in the largest model; matching the remaining image pairs", window.id,
                 at.largest(), frames);
    Attempt all = run_attempt(peak_threshold, tag, true);
    all.name = tag.empty() ? "fill" : "fill of the retry";
    res.filled = true;
    if (all.status == BackStatus::kCancelled) {
      cancelled = all.message;
      return false;
    }
    adopt_if_larger(std::move(all), "matching the remaining pairs failed: ", "selected pairs: ", &res.fill_kept);
    return true;
  };
  // The COLMAP names of the frames (not blank) that `a` left out, and of
  // those at most `margin` frames from one of them. Left out: not in the
  // model that holds most of the frame's part (short_of_frames' parts), so a
  // smaller model the part also split into counts as left out (generated
  // weak seed 3: 88 + 22 frames in two models and 8 in none; the retry of
  // the 8 alone gave 88 + 22 again, a full one 110 in one model).
  const auto left_out = [&](const Attempt& a, int margin) {
    const int n = int(window.frames.size());
    std::unordered_map<Timestamp, int> index;
    std::vector<size_t> part(n);
    for (int i = 0; i < n; ++i) {
      index[window.frames[i].timestamp] = i;
      part[i] = size_t(std::upper_bound(part_bounds.begin(), part_bounds.end(), window.frames[i].timestamp) -
                       part_bounds.begin());
    }
    // Per part, the frames of its best model: the one holding most of it, the larger on a tie.
    std::vector<int> best(part_bounds.size() + 1, 0);
    std::vector<std::vector<int>> kept(part_bounds.size() + 1);
    for (const Built& b : a.built) {
      std::vector<std::vector<int>> in(part_bounds.size() + 1);
      for (const Keyframe& k : b.submap.keyframes) {
        const auto it = index.find(k.timestamp);
        if (it != index.end()) in[part[it->second]].push_back(it->second);
      }
      for (size_t p = 0; p < in.size(); ++p)
        if (int(in[p].size()) > best[p]) best[p] = int(in[p].size()), kept[p] = std::move(in[p]);
    }
    std::vector<bool> in_best(n, false);
    for (const auto& frames_of_part : kept)
      for (const int i : frames_of_part) in_best[i] = true;
    std::vector<bool> take(n, false);
    for (int i = 0; i < n; ++i)
      if (!blank[i] && !in_best[i])
        for (int j = std::max(0, i - margin); j <= std::min(n - 1, i + margin); ++j) take[j] = !blank[j];
    std::vector<std::string> names;
    for (int i = 0; i < n; ++i)
      if (take[i]) names.push_back(ColmapImageName(window.frames[i].timestamp));
    return names;
  };
  // What the first attempt left out decides what comes next. A frame with few
  // SIFT features at the first threshold (a plain wall) needs the lower one:
  // no pair makes up for missing features, and the textured frames beyond
  // it stay unlinked too. So does a frame whose selected pairs (its temporal
  // neighbours among them) gave no verified pair with a frame kept: its
  // features do not match, and more pairs seldom change that. When at least
  // a quarter of the frames left out (left_out) are such, the retry goes first
  // and the fill only follows if the retry is still short (a generated
  // corridor window: 16 of the 33 frames in no model had under 100 features;
  // the fill added 1, the retry all 73. A weak-texture window: 5 of 12 with
  // no verified pair to the model; fill then retry 247-352 CPU s, the retry
  // alone 134-142. Blur and drop windows: every frame left out had 23-222
  // inliers to the model, and the fill registered them).
  bool retry_first = false;
  std::string fill_tag;  // the attempt whose database a later fill matches
  if (can_fill && can_retry && options_.retry_first_below_features > 0 && short_of_frames(at)) {
    const std::string db = (ws / "database.db").string();
    std::unordered_map<std::string, int> features;
    std::vector<std::pair<std::string, std::string>> verified;
    if (!ReadColmapKeypointCounts(db, &features, &why) ||
        !ReadColmapVerifiedPairs(db, kColmapMinInliers, &verified, &why)) {
      spdlog::debug("window {}: {}", window.id, why);
    } else {
      const std::vector<std::string> missing = left_out(at, 0);
      const std::unordered_set<std::string> out(missing.begin(), missing.end());
      std::unordered_set<std::string> linked;  // frames left out verified with a frame kept
      for (const auto& [a, b] : verified) {
        if (out.count(a) && !out.count(b)) linked.insert(a);
        if (out.count(b) && !out.count(a)) linked.insert(b);
      }
      int poor = 0, unlinked = 0;
      for (const std::string& name : missing) {
        const auto it = features.find(name);
        if (it == features.end() || it->second < options_.retry_first_below_features)
          ++poor;
        else
          unlinked += !linked.count(name);
      }
      retry_first = poor + unlinked > 0 && 4 * (poor + unlinked) >= int(missing.size());
      if (retry_first)
        spdlog::info("window {}: of the {} frames left out of the largest models, {} have fewer than {} SIFT "
                     "features and {} no verified pair with a frame in one: the retry goes before the fill",
                     window.id, missing.size(), poor, options_.retry_first_below_features, unlinked);
    }
  }
  if (can_fill && !retry_first && short_of_frames(at) && !fill("", options_.sift_peak_threshold))
    return finish(BackStatus::kCancelled, cancelled);
  // Texture-poor windows (a plain corridor wall) give SIFT too few features at
  // the usual threshold: when the largest model misses too many frames, the
  // whole window is tried again with a lower one and the larger model kept.
  if (can_retry && short_of_frames(at)) {
    spdlog::info("window {}: {}/{} frames in the largest model; retrying with SIFT peak threshold {}", window.id,
                 at.largest(), frames, options_.retry_peak_threshold);
    // Frames the largest models hold keep their features and their matches
    // with each other; those left out are extracted again at the lower
    // threshold and only their pairs are matched (COLMAP skips what the copy
    // holds). So are the kept frames up to pairs.overlap from one left out: where
    // a model ends against a plain stretch its last frames are poor at the
    // first threshold too (generated corridor seed 2, a first model of frames
    // 0-19: 42-172 features on 15-19; without them the retry held 53 or 56
    // of 73 frames, with them 73).
    if (options_.retry_reuses_features) {
      const std::vector<std::string> again = left_out(at, options_.pairs.overlap);
      int forgotten = 0;
      if (CopyColmapDatabase((ws / "database.db").string(), (ws / "database_retry.db").string(), again,
                             &forgotten, &why))
        spdlog::info("window {}: the retry keeps the features of {} frames of the largest models and extracts {} "
                     "again",
                     window.id, frames - forgotten, forgotten);
      else
        spdlog::warn("window {}: the retry extracts every frame again: {}", window.id, why);
    }
    Attempt retry = run_attempt(options_.retry_peak_threshold, "_retry");
    retry.name = "retry";
    res.retried = true;
    if (retry.status == BackStatus::kCancelled) return finish(retry.status, retry.message);
    // A fill after it matches the retry's features (more of them) unless the retry failed or is smaller.
    if (retry.status == BackStatus::kOk && retry.largest() >= at.largest()) fill_tag = "_retry";
    adopt_if_larger(std::move(retry), "retry with a lower SIFT threshold failed: ", "first attempt: ", &res.retry_kept);
  }
  if (can_fill && retry_first && short_of_frames(at) &&
      !fill(fill_tag, fill_tag.empty() ? options_.sift_peak_threshold : options_.retry_peak_threshold))
    return finish(BackStatus::kCancelled, cancelled);
  res.warnings.insert(res.warnings.end(), at.warnings.begin(), at.warnings.end());
  // Every model cut at the blank stretches; `warnings` (if any) says what was cut.
  const auto cut_models = [&](std::vector<Built> built, std::vector<std::string>* warnings) {
    std::vector<Built> cut;
    for (Built& b : built) {
      std::vector<Submap> pieces = CutAtStretches(b.submap, stretches, options_.min_registered_images,
                                                  options_.min_point_observations);
      if (pieces.size() == 1 && pieces[0].keyframes.size() == b.submap.keyframes.size()) {
        cut.push_back(std::move(b));
        continue;
      }
      std::string sizes;
      for (Submap& p : pieces) {
        Built piece{std::move(p), b.stats};
        BackSubmapStats& st = piece.stats;
        st.registered_images = int(piece.submap.keyframes.size());
        st.num_points = int(piece.submap.points.size());
        st.num_observations = 0;
        for (const MapPoint& mp : piece.submap.points) st.num_observations += int(mp.observations.size());
        st.mean_track_length = st.num_points > 0 ? double(st.num_observations) / st.num_points : 0.0;
        sizes += (sizes.empty() ? "" : " + ") + std::to_string(st.registered_images);
        cut.push_back(std::move(piece));
      }
      if (warnings)
        warnings->push_back("a model of " + std::to_string(b.stats.registered_images) +
                            " frames cut at a blank stretch (the camera saw nothing): " +
                            (sizes.empty() ? "no side kept" : sizes + " frames kept"));
    }
    return cut;
  };
  if (!stretches.empty()) {
    // Each side of a stretch takes its models from the attempt that registered
    // most of it, the earliest on a tie. A fill or a retry that joined the two
    // places (through a poster on two walls) bent the side it shared with the
    // first attempt: generated `kidnap` seed 5, the same 38 frames at 0.0026 m
    // in the first attempt, 0.0118 m after the fill's model was cut.
    std::vector<std::vector<Built>> pieces;
    for (Attempt& a : tried) pieces.push_back(cut_models(std::move(a.built), nullptr));
    const size_t adopted = [&] {
      for (size_t k = 0; k < tried.size(); ++k)
        if (tried[k].name == at.name) return k;
      return size_t{0};
    }();
    pieces[adopted] = cut_models(std::move(at.built), &res.warnings);
    std::vector<Built> kept;
    for (size_t side = 0; side <= stretches.size(); ++side) {
      const Timestamp from = side == 0 ? std::numeric_limits<Timestamp>::min() : stretches[side - 1].second;
      const Timestamp to = side == stretches.size() ? std::numeric_limits<Timestamp>::max() : stretches[side].first;
      const auto in_side = [&](const Built& b) {
        const Timestamp t = b.submap.keyframes.front().timestamp;
        return t > from && t < to;
      };
      size_t best = adopted;
      int best_size = 0;
      for (size_t k = 0; k < pieces.size(); ++k) {
        int size = 0;
        for (const Built& b : pieces[k])
          if (!b.submap.keyframes.empty() && in_side(b)) size = std::max(size, b.stats.registered_images);
        if (size > best_size) best = k, best_size = size;
      }
      if (best != adopted && best_size > 0)
        res.warnings.push_back("side " + std::to_string(side + 1) + " of the blank stretches: the " + tried[best].name +
                               "'s model of " + std::to_string(best_size) + " frames kept");
      for (Built& b : pieces[best])
        if (!b.submap.keyframes.empty() && in_side(b)) kept.push_back(std::move(b));
    }
    std::stable_sort(kept.begin(), kept.end(), [](const Built& x, const Built& y) {
      return x.stats.registered_images > y.stats.registered_images;
    });
    at.built = std::move(kept);
  }
  if (options_.orb_features > 0) {
    OrbExtractorOptions oo;
    oo.num_features = options_.orb_features;
    OrbExtractor orb(oo);
    for (Built& b : at.built) {
      int added = 0;
      for (Keyframe& kf : b.submap.keyframes) {
        const auto it = colmap_images.find(kf.timestamp);
        if (it != colmap_images.end()) added += AddOrbKeypoints(it->second, &orb, &kf);
      }
      spdlog::debug("window {}: {} ORB keypoints on {} keyframes", window.id, added, b.submap.keyframes.size());
    }
  }
  for (Built& b : at.built) {
    b.submap.id = next_submap_id_++;
    res.num_registered += b.stats.registered_images;
    res.submaps.push_back(std::move(b.submap));
    res.stats.push_back(b.stats);
  }
  for (const std::string& w : res.warnings) spdlog::info("window {}: {}", window.id, w);
  if (res.submaps.empty()) {
    return finish(BackStatus::kNoModel,
                  at.models == 0 ? "mapper produced no model (no initial pair?)"
                                 : "all models smaller than min_registered_images");
  }
  return finish(BackStatus::kOk, "");
}

}  // namespace rumi
