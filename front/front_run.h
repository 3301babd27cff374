#pragma once
// rumi-front as a process (`rumi-front --instance ID --out DIR ...`,
// docs/front.md): frames from the configured source (a dataset replayed
// live, a camera, a video file, an HTTP MJPEG stream) through the Front;
// windows and front submaps go out over the instance's channels
// (FrontPublisher). rumi-front's main, `rumi eval run` and rumid all run it
// through RunFront.
#include <atomic>

#include "front/frame_stream.h"
#include "front/front_options.h"
#include "front/front_publisher.h"
#include "front/sampler.h"
#include "ipc/channels.h"

namespace rumi {

struct FrontRunOptions {
  StreamOpenOptions stream;          // source:, the camera, the replay start
  FrontOptions front;
  SamplerOptions sampler;
  FrontPublisherOptions publisher;   // publisher.out_dir is RUNDIR (required)
  IpcOptions ipc;                    // ipc.instance = --instance
  int64_t first_submap_id = 0;       // and first window id (rumid: unique across restarts)
  int max_frames = 0;                // stop after N delivered + skipped frames (0: all)
};

// Runs to the end of the stream, or until *stop is set. Returns the exit code
// (common/process/exit_codes.h): done; stopped before the end; bad input (the
// source cannot be opened, a frame of the wrong size, an unreadable pose
// file); nothing processed (not one frame reached the front); error.
int RunFront(const FrontRunOptions& o, const std::atomic<bool>* stop);

}  // namespace rumi
