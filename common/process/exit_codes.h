#pragma once
// Exit codes shared by rumi-front, rumi-back, rumi-manager and rumid, so a
// supervisor (`rumi eval run`, rumid) can tell a finished child from one that
// was stopped early, failed, or was started wrongly (docs/eval.md).
namespace rumi {

enum ExitCode : int {
  kExitDone = 0,              // the work is complete (end of stream; producers closed and drained)
  kExitError = 1,             // runtime error (an output cannot be written, a channel refused)
  kExitBadInput = 2,          // bad command line, config or input: restarting will not help
  kExitNoProducer = 3,        // manager: no producer appeared at all
  kExitWindowFailed = 4,      // back, file mode: the window gave no model
  kExitStopped = 5,           // stopped by SIGTERM/SIGINT before the work was done (outputs saved)
  kExitPeerGone = 6,          // a peer this process works for vanished and did not come back
  kExitNothingProcessed = 7,  // front: not one frame could be used
};

// "done", "stopped before its work was done", ...
const char* DescribeExitCode(int code);

}  // namespace rumi
