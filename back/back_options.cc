#include "back/back_options.h"

#include <filesystem>

namespace rumi {

const OptionSpec<BackOptions>& BackOptions::Spec() {
  using O = BackOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("back");
    s->Text("colmap_path", &O::colmap_path, "COLMAP executable (PATH lookup when no '/')", true);
    s->Text("workspace_dir", &O::workspace_dir, "root of per-window COLMAP workspaces; '': $TMPDIR/rumi-back");
    s->Flag("keep_workspaces", &O::keep_workspaces, "keep each window's COLMAP folder (debugging)");
    s->Number("num_threads", &O::num_threads, AtLeast(1), AtMost(64), "threads per COLMAP step");
    s->Number("max_num_features", &O::max_num_features, AtLeast(64), AtMost(65536), "SIFT features per image");
    s->Number("sift_first_octave", &O::sift_first_octave, AtLeast(-1), AtMost(2), "-1 upsamples (slower)");
    s->Number("sift_upsample_below_width", &O::sift_upsample_below_width, AtLeast(0), AtMost(100000),
              "images narrower than this are upsampled anyway; 0: never");
    s->Choice("matcher", &O::matcher, {"pairs", "exhaustive", "sequential"},
              "which image pairs COLMAP matches (pairs: pair_selection.h)");
    s->Section("pairs", &O::pairs, PairSelectionOptions::Spec());
    s->Number("sequential_overlap", &O::sequential_overlap, AtLeast(1), AtMost(1000),
              "neighbours matched by the sequential matcher");
    s->Number("step_timeout_s", &O::step_timeout_s, Above(0.0), AtMost(86400.0),
              "per COLMAP step; its process group is killed after it");
    s->Number("min_registered_images", &O::min_registered_images, AtLeast(2), AtMost(100000),
              "smaller models are dropped");
    s->Number("mapper_min_model_size", &O::mapper_min_model_size, AtLeast(2), AtMost(100000),
              "COLMAP Mapper.min_model_size: smaller models are discarded while mapping");
    s->Number("blank_max_stddev", &O::blank_max_stddev, AtLeast(0.0), AtMost(255.0),
              "frames whose 8x8 block means have at most this grey-level standard deviation (and blank_max_structure) are blank; a "
              "model is cut at a blank stretch (0: never)");
    s->Number("blank_min_frames", &O::blank_min_frames, AtLeast(1), AtMost(100000),
              "consecutive blank frames that make a stretch");
    s->Number("blank_max_structure", &O::blank_max_structure, AtLeast(-1.0), AtMost(1.0),
              "a blank frame's block means are also uncorrelated: their correlation with the next block is at "
              "most this (noise ~0; a near-black scene or a plain wall keeps its structure)");
    s->Number("pose_jump_ratio", &O::pose_jump_ratio, AtLeast(0.0), AtMost(1e6),
              "a keyframe farther from both time neighbours than this many times the median speed (or step) "
              "is left out of the back submap (0: keep all)");
    s->Number("min_point_observations", &O::min_point_observations, AtLeast(2), AtMost(100000),
              "points seen by fewer images are dropped");
    s->Number("track_completion_px", &O::track_completion_px, AtLeast(0.0), AtMost(20.0),
              "track completion radius by reprojection; 0: off");
    s->Number("orb_features", &O::orb_features, AtLeast(0), AtMost(20000),
              "ORB keypoints added to each back keyframe (0: off, else >= 50)");
    s->Number("max_queue_windows", &O::max_queue_windows, AtLeast(1), AtMost(1000),
              "windows waiting; the oldest is dropped beyond it");
    s->Number("merge_gap_s", &O::merge_gap_s, AtLeast(-1.0), AtMost(3600.0),
              "a window starting this close to the end of the last waiting one joins it; < 0: never");
    s->Number("merge_max_frames", &O::merge_max_frames, AtLeast(1), AtMost(100000),
              "no join that would make a window of more frames than this");
    s->Flag("low_priority", &O::low_priority, "SCHED_IDLE (or nice 19) for rumi-back and COLMAP");
    s->Number("wait_for_producer_s", &O::wait_for_producer_s, AtLeast(0.0), AtMost(86400.0),
              "no window producer after this long: done (0: wait forever)");
    s->Number("wait_for_consumer_s", &O::wait_for_consumer_s, AtLeast(0.0), AtMost(86400.0),
              "at the end, wait this long for the manager to read every back submap");
    s->Number("peer_timeout_s", &O::peer_timeout_s, Above(0.0), AtMost(86400.0),
              "a manager gone this long (not restarted) ends the back (exit 6)");
    s->Flag("normalize_contrast", &O::normalize_contrast, "stretch grey levels of dark or washed-out frames");
    s->Number("sift_peak_threshold", &O::sift_peak_threshold, AtLeast(0.0), AtMost(1.0),
              "COLMAP SiftExtraction.peak_threshold; 0: COLMAP's default");
    s->Number("retry_peak_threshold", &O::retry_peak_threshold, AtLeast(0.0), AtMost(1.0),
              "peak threshold of the retry; 0: never retry");
    s->Number("retry_below_registered", &O::retry_below_registered, AtLeast(0.0), AtMost(1.0),
              "retry when the largest model holds less than this share of the window");
    s->Number("retry_first_below_features", &O::retry_first_below_features, AtLeast(0), AtMost(100000),
              "retry before the fill when a quarter of the frames left out have fewer SIFT features or no "
              "verified pair; 0: fill first");
    s->Flag("retry_reuses_features", &O::retry_reuses_features,
            "the retry keeps the features and matches of the frames the largest models hold");
    s->Flag("sift_domain_size_pooling", &O::sift_domain_size_pooling, "DSP-SIFT descriptors");
    s->Choice("mode", &O::mode, {"local", "remote", "both"},
              "where windows are built: here, on rumi-back --remote workers over DDS, or remote with a local fallback");
    s->Number("remote_claim_timeout_s", &O::remote_claim_timeout_s, Above(0.0), AtMost(3600.0),
              "mode both: built here when no worker claims a window within this long");
    s->Number("remote_lease_s", &O::remote_lease_s, Above(0.0), AtMost(86400.0),
              "a worker silent this long is taken for dead and its window offered again");
    s->Flag("remote_png", &O::remote_png, "windows go to remote workers with PNG frames (lossless)");
    s->Rule("orb_features must be 0 (off) or in [50, 20000]",
            [](const O& o) { return o.orb_features == 0 || o.orb_features >= 50; });
    return s;
  }();
  return *spec;
}

bool BackOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

std::string BackOptions::WorkspaceRoot() const {
  if (!workspace_dir.empty()) return workspace_dir;
  std::error_code ec;
  std::filesystem::path tmp = std::filesystem::temp_directory_path(ec);
  if (ec) tmp = "/tmp";
  return (tmp / "rumi-back").string();
}

}  // namespace rumi
