#pragma once
// rumi-back as a process (`rumi-back --instance ID --work DIR`, docs/back.md):
// windows from the instance's window channel, back submaps to the manager.
// rumi-back's main, `rumi eval run` and rumid all run it through RunBack.
#include <atomic>
#include <functional>
#include <string>

#include "back/back_options.h"
#include "back/back_submap_builder.h"
#include "ipc/channels.h"

namespace rumi {

// Builds a window somewhere else: back/remote's DDS dispatcher (back.mode
// remote or both). Returns false when nobody took the window and it is to be
// built here (mode both; result->remote still says what the offer cost);
// true with the result otherwise (a cancel gives a kCancelled result). The
// submaps are numbered from first_submap_id.
class RemoteWindowBuilder {
 public:
  virtual ~RemoteWindowBuilder() = default;
  virtual bool Build(const ImageWindow& w, int64_t first_submap_id, const std::atomic<bool>* cancel,
                     const std::function<void(const std::string&)>& stage, BackResult* result) = 0;
};

struct BackRunOptions {
  BackOptions back;                 // also the run loop's waits (back.wait_for_*)
  IpcOptions ipc;                   // ipc.instance = --instance
  std::string work_dir;             // back_stats.json (and spool/) go here
  // rumid: a received window is written to work_dir/spool before its ring
  // slot is released and stays until it is built, so a restarted back
  // retries the window it was on (once; a second death drops it) and loses
  // none of the queued ones.
  bool spool = false;
  // `rumi eval run`: a window producer that died ends the stream. rumid: it is
  // restarted, so the back waits for it.
  bool producer_death_ends = true;
  bool keep_segments = false;       // rumid: see RingProducer::KeepSegmentOnClose
  int64_t first_submap_id = 0;      // rumid: unique across restarts
  // rumid: a closed window channel ends the back only once this is set
  // (SIGUSR1: the source ended); before, a closed channel may be a front
  // that is being restarted. nullptr (`rumi eval run`): a closed channel ends it.
  const std::atomic<bool>* finish = nullptr;
  RemoteWindowBuilder* remote = nullptr;  // back.mode remote/both (rumi-back's main makes it)
};

// Runs until the window producer has closed its channel (or, with
// producer_death_ends, died; or never appeared within back.wait_for_producer_s)
// and every queued window is built, or until *stop is set (the running
// COLMAP step is cancelled). Writes work_dir/back_stats.json after every
// window and at the end; reports its status to a supervisor (notify).
// Returns the exit code (common/process/exit_codes.h): done, stopped before
// done, peer gone (the manager vanished for back.peer_timeout_s), error.
int RunBack(const BackRunOptions& o, const std::atomic<bool>* stop);

}  // namespace rumi
