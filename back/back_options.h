#pragma once
// Options of the back: how COLMAP is run on one sampled window and what is
// kept of the result. Read from the `back:` section of a rumi config.
#include <string>

#include "back/pair_selection.h"
#include "common/option_spec.h"

namespace rumi {

struct BackOptions {
  std::string colmap_path = "colmap";  // executable (PATH lookup when no '/')
  std::string workspace_dir;           // root of per-window workspaces; "" = $TMPDIR/rumi-back
  bool keep_workspaces = false;        // keep each window's COLMAP folder (debugging)
  int num_threads = 2;                 // per COLMAP step (extraction, matching, mapping)
  int max_num_features = 2048;         // SIFT features per image
  int sift_first_octave = 0;           // -1 upsamples (COLMAP default, slower); 0 is enough at VGA
  // Images narrower than this are upsampled anyway (first octave -1): at
  // 320x240, octave 0 left 6 of 56 frames of a generated blur window out of
  // the model, -1 registered all 56. 0 = never.
  int sift_upsample_below_width = 640;
  // "pairs": the pairs of pair_selection.h (COLMAP matches_importer);
  // "exhaustive": every pair; "sequential": neighbours by name = time order.
  std::string matcher = "pairs";
  PairSelectionOptions pairs;
  int sequential_overlap = 10;         // neighbours matched by the sequential matcher
  double step_timeout_s = 600.0;       // per COLMAP step; the process group is killed after it
  int min_registered_images = 3;       // smaller models are dropped
  // COLMAP's Mapper.min_model_size (its default, 10; COLMAP lowers it to the
  // image count for smaller windows). A smaller model is discarded and its
  // images stay free for the next initial pair. At 3, a 3-image model kept
  // after a failed start left no initial pair for the rest: a generated
  // corridor window's retry registered 3 of 71 frames in a rumi eval run
  // (71 of 71 from the same database at 5 and at 10), so the lost stretch
  // was never merged.
  int mapper_min_model_size = 10;
  // A model is cut at a stretch of at least blank_min_frames window frames
  // that show only noise: their 8 x 8 block means are flat (grey-level
  // standard deviation at most blank_max_stddev) and uncorrelated (with the
  // next block at most blank_max_structure): a covered lens, not a dark
  // room or a plain wall (back/blank_cut.h). The sides become back submaps
  // of their own. blank_max_stddev 0 = never.
  double blank_max_stddev = 1.0;
  double blank_max_structure = 0.3;
  int blank_min_frames = 3;
  // A keyframe whose centre neither time neighbour can reach (more than
  // pose_jump_ratio x the median speed x the time apart, or x the median
  // step) while they agree with each other is left out (back/pose_jumps.h).
  // 0 = keep every registered frame.
  double pose_jump_ratio = 10.0;
  // Points seen by fewer images are dropped from the back submap: SfM keeps
  // two-view points that ORB-SLAM's map-point rule would cull (2 keeps all).
  int min_point_observations = 3;
  // Before that, tracks are completed by reprojection (CompleteTracks): a
  // free SIFT keypoint within this radius of a point's projection becomes an
  // observation. The pairwise matcher misses many on dark or noisy frames,
  // leaving short tracks that make every keyframe look necessary to
  // post-culling. 0 = off. (2 px culled 42 % of the dark demo's back
  // keyframes, 3 px with the manager's front-point search 53 %; merges and
  // ATE the same, docs/manager.md.)
  double track_completion_px = 3.0;
  // ORB keypoints (with descriptors, no map point) added to every back
  // keyframe, detected like the front's: the manager finds front map points
  // in back keyframes with them, so that post-culling sees which back
  // keyframes only repeat what the front mapped. 0 = off.
  int orb_features = 1000;
  int max_queue_windows = 2;           // windows waiting; the oldest is dropped beyond it
  // A window that starts within merge_gap_s of the end of the last waiting
  // one joins it (one COLMAP run for two close losses, and no drop), unless
  // the joined window would hold more than merge_max_frames. < 0: never.
  double merge_gap_s = 3.0;
  int merge_max_frames = 300;
  // The run loop (rumi-back with channels): a window producer not seen after
  // wait_for_producer_s counts as never appeared (0: wait forever); at the
  // end, wait up to wait_for_consumer_s for the manager to read every back
  // submap; a manager gone for peer_timeout_s (not restarted) ends the back.
  double wait_for_producer_s = 0.0;
  double wait_for_consumer_s = 30.0;
  double peer_timeout_s = 60.0;
  bool low_priority = true;            // SCHED_IDLE (or nice 19) for rumi-back and COLMAP
  // Dark or washed-out frames (the ones the front loses) give SIFT too few
  // features at COLMAP's absolute peak threshold: stretch their grey levels.
  bool normalize_contrast = true;
  // COLMAP SiftExtraction.peak_threshold; 0 = COLMAP's default (0.0067).
  // Lower: motion-blurred frames keep enough features (docs/back.md).
  double sift_peak_threshold = 0.004;
  // When the largest model holds fewer than retry_below_registered of the
  // window's frames, the window is run again with this peak threshold and
  // the larger model kept (0 = never). A plain corridor turn: 44/93 frames at
  // 0.004, 93/93 at 0.0015 (docs/synth.md).
  double retry_peak_threshold = 0.0015;
  double retry_below_registered = 0.9;
  // When at least a quarter of the frames the first attempt left out of
  // the largest models (blank ones aside) have fewer SIFT features than
  // this, or no verified pair with a frame kept, the retry goes before the
  // fill: no pair makes up for features that do not match. 0 = the fill first.
  int retry_first_below_features = 100;
  // The retry keeps the features and matches of the frames the largest
  // models hold (copied from the first attempt's database): only the frames
  // left out, and those within pairs.overlap of one, are extracted again at
  // the lower threshold, and only their pairs matched (generated corridor
  // seed 2: 162-201 -> 109-113 CPU s, the same 73/73 frames; docs/back.md
  // step 8). Off: the retry extracts and matches everything.
  bool retry_reuses_features = true;
  // COLMAP SiftExtraction.domain_size_pooling (DSP-SIFT: descriptors pooled
  // over several patch sizes; CPU extraction only). Off: better on one dark
  // window (lost frames 0.016-0.023 -> 0.011 m), not end to end (docs/back.md).
  bool sift_domain_size_pooling = false;

  // Where windows are built (back/remote/, docs/back.md "Remote workers"):
  // "local" (COLMAP here), "remote" (offered to `rumi-back --remote` workers
  // over Cyclone DDS, on the `dds:` section's domain and interface; a window
  // waits until a worker takes it) or "both" (remote, built here when no
  // worker claims it within remote_claim_timeout_s).
  std::string mode = "local";
  double remote_claim_timeout_s = 5.0;
  // A worker that sends no progress for this long is taken for dead: the
  // window is offered again (a late result of the old attempt is dropped).
  double remote_lease_s = 20.0;
  // Windows go to remote workers with PNG frames (lossless; the shared-memory
  // ring stays raw): 50-66 % of the raw bytes for about 10 ms a frame on
  // the dispatcher (docs/back.md, Remote workers). Off: raw, as on the ring.
  bool remote_png = true;

  static const OptionSpec<BackOptions>& Spec();  // section `back:`
  bool Check(std::string* why = nullptr) const;
  // Resolved workspace root (workspace_dir or the default under $TMPDIR).
  std::string WorkspaceRoot() const;
};

}  // namespace rumi
