#include "common/process/exit_codes.h"

namespace rumi {

const char* DescribeExitCode(int code) {
  switch (code) {
    case kExitDone: return "done";
    case kExitError: return "runtime error";
    case kExitBadInput: return "bad command line, config or input";
    case kExitNoProducer: return "no producer appeared";
    case kExitWindowFailed: return "the window gave no model";
    case kExitStopped: return "stopped before its work was done";
    case kExitPeerGone: return "a peer vanished and did not come back";
    case kExitNothingProcessed: return "no frame could be used";
  }
  if (code >= 100 && code <= 114) return "rejected its command line";
  return "failed";
}

}  // namespace rumi
