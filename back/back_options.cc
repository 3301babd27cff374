#include "back/back_options.h"

#include <filesystem>

namespace rumi {

bool BackOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (colmap_path.empty()) return fail("colmap_path is empty");
  if (num_threads < 1 || num_threads > 64) return fail("num_threads must be in [1, 64]");
  if (max_num_features < 64 || max_num_features > 65536)
    return fail("max_num_features must be in [64, 65536]");
  if (!(sift_peak_threshold >= 0.0 && sift_peak_threshold <= 1.0))
    return fail("sift_peak_threshold must be in [0, 1]");
  if (!(retry_peak_threshold >= 0.0 && retry_peak_threshold <= 1.0))
    return fail("retry_peak_threshold must be in [0, 1]");
  if (!(retry_below_registered >= 0.0 && retry_below_registered <= 1.0))
    return fail("retry_below_registered must be in [0, 1]");
  if (sift_first_octave < -1 || sift_first_octave > 2) return fail("sift_first_octave must be in [-1, 2]");
  if (sift_upsample_below_width < 0) return fail("sift_upsample_below_width must be >= 0");
  if (matcher != "exhaustive" && matcher != "sequential")
    return fail("matcher must be 'exhaustive' or 'sequential' (got '" + matcher + "')");
  if (sequential_overlap < 1) return fail("sequential_overlap must be >= 1");
  if (!(step_timeout_s > 0.0)) return fail("step_timeout_s must be > 0");
  if (min_registered_images < 2) return fail("min_registered_images must be >= 2");
  if (min_point_observations < 2) return fail("min_point_observations must be >= 2");
  if (!(track_completion_px >= 0 && track_completion_px <= 20)) return fail("track_completion_px must be in [0, 20]");
  if (orb_features != 0 && (orb_features < 50 || orb_features > 20000))
    return fail("orb_features must be 0 (off) or in [50, 20000]");
  if (max_queue_windows < 1) return fail("max_queue_windows must be >= 1");
  return true;
}

std::string BackOptions::WorkspaceRoot() const {
  if (!workspace_dir.empty()) return workspace_dir;
  std::error_code ec;
  std::filesystem::path tmp = std::filesystem::temp_directory_path(ec);
  if (ec) tmp = "/tmp";
  return (tmp / "rumi-back").string();
}

void ReadOptions(ConfigSection& s, BackOptions* o) {
  s.Read("colmap_path", &o->colmap_path);
  s.Read("workspace_dir", &o->workspace_dir);
  s.Read("keep_workspaces", &o->keep_workspaces);
  s.ReadInRange("num_threads", &o->num_threads, 1, 64);
  s.ReadInRange("max_num_features", &o->max_num_features, 64, 65536);
  s.Read("normalize_contrast", &o->normalize_contrast);
  s.Read("sift_domain_size_pooling", &o->sift_domain_size_pooling);
  s.ReadInRange("sift_peak_threshold", &o->sift_peak_threshold, 0.0, 1.0);
  s.ReadInRange("retry_peak_threshold", &o->retry_peak_threshold, 0.0, 1.0);
  s.ReadInRange("retry_below_registered", &o->retry_below_registered, 0.0, 1.0);
  s.ReadInRange("sift_first_octave", &o->sift_first_octave, -1, 2);
  s.ReadInRange("sift_upsample_below_width", &o->sift_upsample_below_width, 0, 100000);
  if (s.Read("matcher", &o->matcher) && o->matcher != "exhaustive" && o->matcher != "sequential")
    s.Fail("matcher", "must be 'exhaustive' or 'sequential'");
  s.ReadInRange("sequential_overlap", &o->sequential_overlap, 1, 1000);
  s.ReadInRange("step_timeout_s", &o->step_timeout_s, 0.001, 86400.0);
  s.ReadInRange("min_registered_images", &o->min_registered_images, 2, 100000);
  s.ReadInRange("min_point_observations", &o->min_point_observations, 2, 100000);
  s.ReadInRange("track_completion_px", &o->track_completion_px, 0.0, 20.0);
  s.ReadInRange("orb_features", &o->orb_features, 0, 20000);
  s.ReadInRange("max_queue_windows", &o->max_queue_windows, 1, 1000);
  s.Read("low_priority", &o->low_priority);
  // Cross-field checks: callers run CheckOptions(o, root, "back").
}

}  // namespace rumi
