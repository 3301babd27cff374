#include "back/colmap_runner.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "back/colmap_model.h"
#include "back/model_to_submap.h"
#include "common/logging.h"
#include "common/pose_jumps.h"
#include "common/process/subprocess.h"

namespace fs = std::filesystem;

namespace rumi {
namespace {

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

// The intrinsics were fixed: a change means the flags or the shift are wrong.
bool SameIntrinsics(const CameraIntrinsics& k, const PinholeCameraOptions& c) {
  return !(std::abs(k.fx - c.fx) > 1e-6 * c.fx || std::abs(k.fy - c.fy) > 1e-6 * c.fy ||
           std::abs(k.cx - c.cx) > 1e-6 || std::abs(k.cy - c.cy) > 1e-6 || k.width != c.width ||
           k.height != c.height);
}

// Every model folder -> one submap into at->built, the largest first;
// models that keep too few frames are dropped with a warning.
void ReadModels(const BackOptions& o, const PinholeCameraOptions& c, const fs::path& sparse, ColmapAttempt* at) {
  const std::vector<fs::path> models = ModelFolders(sparse);
  at->models = models.size();
  for (const fs::path& dir : models) {
    ColmapModel model;
    BuiltModel b;
    std::string why;
    if (!ReadColmapModelBinary(dir.string(), &model, &why) ||
        !ColmapModelToSubmap(model, -1, &b.submap, &b.stats, &why)) {
      at->status = BackStatus::kModelError;
      at->message = dir.string() + ": " + why;
      return;
    }
    if (!SameIntrinsics(b.submap.camera, c)) {
      at->status = BackStatus::kModelError;
      at->message = dir.string() + ": COLMAP changed the fixed intrinsics";
      return;
    }
    const std::string name = sparse.filename().string() + "/" + dir.filename().string();
    const std::vector<size_t> jumps = PoseJumps(b.submap, o.pose_jump_ratio);
    if (!jumps.empty()) {
      std::string which;
      for (size_t i : jumps) which += (which.empty() ? "" : ", ") + FormatSeconds(b.submap.keyframes[i].timestamp);
      at->warnings.push_back(name + ": " + std::to_string(jumps.size()) +
                             " frame(s) registered off the camera path, left out: " + which);
      b.stats.registered_images -= DropKeyframesAt(&b.submap, jumps);
    }
    const int completed = CompleteTracks(&b.submap, o.track_completion_px);
    const int weak = DropWeakPoints(&b.submap, o.min_point_observations);
    spdlog::info("back: {}: {} observations added by track completion, {} weak points dropped",
                 dir.filename().string(), completed, weak);
    b.stats.num_points = static_cast<int>(b.submap.points.size());
    if (b.stats.registered_images < o.min_registered_images) {
      at->warnings.push_back(name + ": dropped, " + std::to_string(b.stats.registered_images) + " registered images");
      continue;
    }
    at->built.push_back(std::move(b));
  }
  std::stable_sort(at->built.begin(), at->built.end(), [](const BuiltModel& x, const BuiltModel& y) {
    return x.stats.registered_images > y.stats.registered_images;
  });
}

}  // namespace

std::string ColmapNumber(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::vector<ColmapStep> ColmapAttemptSteps(const BackOptions& o, const PinholeCameraOptions& c,
                                           const ColmapWorkspace& ws, const AttemptSpec& a, bool blank_stretches) {
  const std::string threads = std::to_string(o.num_threads);
  const std::string db = ws.database(a.tag).string();
  // COLMAP puts the top-left pixel's centre at (0.5, 0.5): shift cx, cy.
  const std::string params = ColmapNumber(c.fx) + "," + ColmapNumber(c.fy) + "," +
                             ColmapNumber(c.cx + kColmapPixelOffset) + "," + ColmapNumber(c.cy + kColmapPixelOffset);
  const int first_octave = c.width < o.sift_upsample_below_width ? -1 : o.sift_first_octave;
  std::vector<ColmapStep> steps;
  if (!a.fill) {
    steps.push_back({"feature_extraction",
                     {"feature_extractor", "--database_path", db, "--image_path", ws.images().string(),
                      "--ImageReader.camera_model", "PINHOLE", "--ImageReader.single_camera", "1",
                      "--ImageReader.camera_params", params, "--SiftExtraction.use_gpu", "0",
                      "--SiftExtraction.num_threads", threads, "--SiftExtraction.max_num_features",
                      std::to_string(o.max_num_features), "--SiftExtraction.first_octave", std::to_string(first_octave)},
                     &BackStepTimes::feature_extraction_s, &BackStepTimes::feature_extraction_cpu_s});
    std::vector<std::string>& args = steps.back().args;
    if (a.peak_threshold > 0) args.insert(args.end(), {"--SiftExtraction.peak_threshold", ColmapNumber(a.peak_threshold)});
    if (o.sift_domain_size_pooling) args.insert(args.end(), {"--SiftExtraction.domain_size_pooling", "1"});
  }
  std::vector<std::string> match;
  if (o.matcher == "sequential")
    match = {"sequential_matcher", "--database_path", db, "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads",
             threads, "--SequentialMatching.overlap", std::to_string(o.sequential_overlap)};
  else if (o.matcher == "pairs" && (!a.fill || blank_stretches))
    match = {"matches_importer", "--database_path", db, "--match_list_path",
             (a.fill ? ws.fill_pairs() : ws.pairs()).string(), "--match_type", "pairs",
             "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads};
  else
    match = {"exhaustive_matcher", "--database_path", db, "--SiftMatching.use_gpu", "0",
             "--SiftMatching.num_threads", threads};
  steps.push_back({"matching", std::move(match), &BackStepTimes::matching_s, &BackStepTimes::matching_cpu_s});
  steps.push_back({"mapping",
                   {"mapper", "--database_path", db, "--image_path", ws.images().string(), "--output_path",
                    ws.sparse(a.tag, a.fill).string(), "--Mapper.num_threads", threads,
                    "--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
                    "--Mapper.ba_refine_extra_params", "0", "--Mapper.min_model_size",
                    std::to_string(o.mapper_min_model_size)},
                   &BackStepTimes::mapping_s, &BackStepTimes::mapping_cpu_s});
  return steps;
}

ColmapRunner::ColmapRunner(const BackOptions& options, const ImageWindow& window, const ColmapWorkspace& ws,
                           bool blank_stretches, const std::atomic<bool>* cancel,
                           const std::function<void(const std::string&)>& on_stage, BackStepTimes* times)
    : options_(options), window_(window), ws_(ws), blank_stretches_(blank_stretches), cancel_(cancel),
      on_stage_(on_stage), times_(times) {}

ColmapAttempt ColmapRunner::Run(const AttemptSpec& a) {
  ColmapAttempt at;
  const fs::path sparse = ws_.sparse(a.tag, a.fill);
  std::error_code ec;
  fs::create_directories(sparse, ec);
  if (ec) {
    at.status = BackStatus::kIoError;
    at.message = "cannot create " + sparse.string() + ": " + ec.message();
    return at;
  }
  for (const ColmapStep& step : ColmapAttemptSteps(options_, window_.camera, ws_, a, blank_stretches_))
    if (!RunStep(step, &at)) return at;
  const auto t_read = std::chrono::steady_clock::now();
  ReadModels(options_, window_.camera, sparse, &at);
  if (at.status != BackStatus::kOk) return at;
  times_->read_convert_s += SecondsSince(t_read);
  return at;
}

bool ColmapRunner::RunStep(const ColmapStep& step, ColmapAttempt* at) {
  RunRequest req;
  req.argv.push_back(options_.colmap_path);
  req.argv.insert(req.argv.end(), step.args.begin(), step.args.end());
  req.log_path = ws_.log().string();
  // glog would also leave a log file per COLMAP run in /tmp, forever.
  req.env = {"GLOG_logtostderr=1"};
  req.timeout_s = options_.step_timeout_s;
  req.low_priority = options_.low_priority;
  req.cancel = cancel_;
  spdlog::debug("window {}: colmap {}", window_.id, step.args[0]);
  if (on_stage_) on_stage_(step.args[0]);
  const RunResult r = RunProcess(req);
  times_->*step.seconds += r.seconds;
  times_->*step.cpu_seconds += r.cpu_seconds;
  if (r.status == RunStatus::kOk) return true;
  at->message = std::string(step.name) + ": " + r.message;
  switch (r.status) {
    case RunStatus::kTimeout: at->status = BackStatus::kTimeout; break;
    case RunStatus::kCancelled: at->status = BackStatus::kCancelled; break;
    default: at->status = BackStatus::kColmapFailed; break;
  }
  return false;
}

}  // namespace rumi
