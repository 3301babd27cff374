#include "back/back_result.h"

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

}  // namespace rumi
