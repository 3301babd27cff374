#include "common/synth/synth_calibration.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "common/synth/synthetic_sequence.h"

namespace rumi {
namespace fs = std::filesystem;

bool SynthCalibrationOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (work_dir.empty()) return fail("work_dir must be set");
  if (!(around_s >= 0 && around_s < 60)) return fail("around_s must be in [0, 60)");
  if (step_outside < 1) return fail("step_outside must be >= 1");
  if (colmap_threads < 1) return fail("colmap_threads must be >= 1");
  if (!(sift_peak_threshold >= 0 && sift_peak_threshold < 1)) return fail("sift_peak_threshold must be in [0, 1)");
  return true;
}

std::string SynthCalibrationReport::Summary() const {
  std::ostringstream s;
  s << "calibration " << scenario << ": window " << window_frames << " images (" << window_inside
    << " inside the stretch, " << dropped << " dropped); ORB inside min/mean/max " << orb_inside_min << "/"
    << static_cast<int>(orb_inside_mean) << "/" << orb_inside_max << ", outside " << orb_outside_min << "/"
    << static_cast<int>(orb_outside_mean) << "/" << orb_outside_max;
  if (registered >= 0) {
    s << "; COLMAP registered " << registered << "/" << window_frames << " ("
      << static_cast<int>(100 * registered_fraction + 0.5) << " %)";
  }
  if (ok) s << " -> OK";
  else if (colmap_ok && registered >= 0)
    s << " -> COLMAP OK, ORB >= 100 inside: fair only if rumi's front loses track there "
         "(rumi eval run SEQ --dataset tum --no-back)";
  else s << " -> NOT MET";
  return s.str();
}

namespace {

void RunOrThrow(const std::string& cmd, const fs::path& log) {
  // GLOG_logtostderr: no glog file per COLMAP run left behind in /tmp.
  const std::string full = "GLOG_logtostderr=1 " + cmd + " >> '" + log.string() + "' 2>&1";
  spdlog::info("calibrate: {}", cmd);
  const int rc = std::system(full.c_str());
  if (rc != 0) throw std::runtime_error("command failed (" + std::to_string(rc) + "), see " + log.string() + ": " + cmd);
}

// Number of registered images in a text model (two lines per image).
int CountModelImagesRaw(const fs::path& images_txt) {
  std::ifstream f(images_txt);
  std::string line;
  int n = 0;
  bool header_line = true;
  while (std::getline(f, line)) {
    if (!line.empty() && line[0] == '#') continue;
    if (header_line) ++n;
    header_line = !header_line;
  }
  return n;
}

}  // namespace

SynthCalibrationReport CalibrateSynth(const SynthOptions& options, const SynthCalibrationOptions& c) {
  std::string why;
  if (!c.Check(&why)) throw std::invalid_argument("calibration options: " + why);
  const SyntheticSequence seq(options);
  SynthCalibrationReport r;
  r.scenario = SynthScenarioName(options.scenario);
  const int pad = static_cast<int>(c.around_s * options.fps);
  const int b = seq.hard_begin(), e = seq.hard_end();
  const int first = std::max(0, b - pad), last = std::min(seq.num_frames() - 1, e - 1 + pad);
  const fs::path work(c.work_dir), images = work / "images";
  fs::remove_all(work / "sparse");
  fs::remove(work / "database.db");
  fs::remove_all(images);
  fs::create_directories(images);
  fs::create_directories(work / "sparse");
  std::vector<int> in_counts, out_counts;
  for (int i = first; i <= last; ++i) {
    const bool inside = seq.in_hard_stretch(i);
    if (!inside && (i - b) % c.step_outside != 0) continue;
    if (seq.dropped(i)) {
      ++r.dropped;
      continue;
    }
    const cv::Mat img = seq.Render(i);
    const int n = CountOrbKeypoints(img);
    (inside ? in_counts : out_counts).push_back(n);
    const fs::path p = images / (TimestampFileStem(seq.timestamp(i)) + ".png");
    if (!cv::imwrite(p.string(), img)) throw std::runtime_error("cannot write " + p.string());
    ++r.window_frames;
    if (inside) ++r.window_inside;
  }
  auto stats = [](const std::vector<int>& v, int* mn, double* mean, int* mx) {
    if (v.empty()) return;
    *mn = *std::min_element(v.begin(), v.end());
    *mx = *std::max_element(v.begin(), v.end());
    double s = 0;
    for (int x : v) s += x;
    *mean = s / v.size();
  };
  stats(in_counts, &r.orb_inside_min, &r.orb_inside_mean, &r.orb_inside_max);
  stats(out_counts, &r.orb_outside_min, &r.orb_outside_mean, &r.orb_outside_max);
  spdlog::info("calibrate {}: {} window images, ORB inside max {}, outside mean {:.0f}", r.scenario,
               r.window_frames, r.orb_inside_max, r.orb_outside_mean);

  const bool orb_ok = options.scenario == SynthScenario::kDrop ? r.dropped > 0
                                                               : (in_counts.empty() || r.orb_inside_max < 100);
  r.orb_ok = orb_ok;
  if (!c.run_colmap) {
    r.ok = orb_ok;
    return r;
  }
  const PinholeCameraOptions& cam = seq.camera();
  const fs::path log = work / "colmap.log";
  const std::string db = (work / "database.db").string();
  const std::string th = std::to_string(c.colmap_threads);
  char params[256];
  // COLMAP puts pixel centres at +0.5.
  std::snprintf(params, sizeof(params), "%.6f,%.6f,%.6f,%.6f", cam.fx, cam.fy, cam.cx + 0.5, cam.cy + 0.5);
  RunOrThrow(c.colmap + " feature_extractor --database_path '" + db + "' --image_path '" + images.string() +
                 "' --ImageReader.camera_model PINHOLE --ImageReader.single_camera 1 --ImageReader.camera_params " +
                 params + " --SiftExtraction.use_gpu 0 --SiftExtraction.num_threads " + th +
                 (c.sift_peak_threshold > 0 ? " --SiftExtraction.peak_threshold " + std::to_string(c.sift_peak_threshold)
                                            : std::string()),
             log);
  RunOrThrow(c.colmap + " exhaustive_matcher --database_path '" + db +
                 "' --SiftMatching.use_gpu 0 --SiftMatching.num_threads " + th,
             log);
  // The mapper exits non-zero when it cannot even initialise: that is a
  // result (nothing registered), not an error of the tool.
  const std::string mapper = c.colmap + " mapper --database_path '" + db + "' --image_path '" + images.string() +
                             "' --output_path '" + (work / "sparse").string() + "' --Mapper.num_threads " + th +
                             " --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0"
                             " --Mapper.ba_refine_extra_params 0";
  spdlog::info("calibrate: {}", mapper);
  if (std::system(("GLOG_logtostderr=1 " + mapper + " >> '" + log.string() + "' 2>&1").c_str()) != 0)
    spdlog::warn("calibrate: COLMAP mapper built no model (see {})", log.string());
  r.registered = 0;
  for (const auto& entry : fs::directory_iterator(work / "sparse")) {
    if (!entry.is_directory()) continue;
    const fs::path txt = entry.path() / "txt";
    fs::create_directories(txt);
    RunOrThrow(c.colmap + " model_converter --input_path '" + entry.path().string() + "' --output_path '" +
                   txt.string() + "' --output_type TXT",
               log);
    r.registered = std::max(r.registered, CountModelImagesRaw(txt / "images.txt"));
  }
  r.registered_fraction = r.window_frames > 0 ? static_cast<double>(r.registered) / r.window_frames : 0.0;
  r.colmap_ok = options.scenario == SynthScenario::kKidnap || r.registered_fraction >= 0.9;
  r.ok = orb_ok && r.colmap_ok;
  return r;
}

cv::Mat SynthContactSheet(const SynthOptions& options, int n, int tw, int th) {
  const SyntheticSequence seq(options);
  const int frames = seq.num_frames();
  std::vector<int> picks;
  if (seq.hard_end() > seq.hard_begin() && n >= 6) {
    const int b = seq.hard_begin(), e = seq.hard_end(), l = e - b;
    const int before = std::max(0, b - static_cast<int>(options.fps)), after = std::min(frames - 1, e + static_cast<int>(options.fps));
    picks = {0, before, b, b + l / 3, b + 2 * l / 3, e - 1, after, frames - 1};
    picks.resize(n, frames - 1);
  } else {
    for (int k = 0; k < n; ++k) picks.push_back(static_cast<int>(static_cast<long>(k) * (frames - 1) / std::max(1, n - 1)));
  }
  const int cols = (n + 1) / 2, rows = n > 1 ? 2 : 1;
  cv::Mat sheet(rows * th, cols * tw, CV_8UC1, cv::Scalar(0));
  for (int k = 0; k < n; ++k) {
    const int i = picks[k];
    cv::Mat small;
    cv::resize(seq.Render(i), small, cv::Size(tw, th), 0, 0, cv::INTER_AREA);
    if (seq.in_hard_stretch(i)) cv::rectangle(small, cv::Rect(0, 0, tw, th), cv::Scalar(255), 2);
    if (seq.dropped(i)) {
      cv::line(small, cv::Point(0, 0), cv::Point(tw - 1, th - 1), cv::Scalar(255), 2);
      cv::line(small, cv::Point(tw - 1, 0), cv::Point(0, th - 1), cv::Scalar(255), 2);
    }
    const std::string label = "#" + std::to_string(i) + (seq.dropped(i) ? " dropped" : (seq.in_hard_stretch(i) ? " hard" : ""));
    cv::putText(small, label, cv::Point(4, th - 6), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0), 3);
    cv::putText(small, label, cv::Point(4, th - 6), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255), 1);
    small.copyTo(sheet(cv::Rect((k % cols) * tw, (k / cols) * th, tw, th)));
  }
  return sheet;
}

}  // namespace rumi
