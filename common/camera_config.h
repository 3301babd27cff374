#pragma once
// Reads a PinholeCameraOptions from a rumi config's `camera:` section:
//   camera: {width: 640, height: 480, fx: .., fy: .., cx: .., cy: ..,
//            k1: 0, k2: 0, p1: 0, p2: 0, k3: 0}
#include "common/camera.h"
#include "common/config.h"

namespace rumi {

// Keys absent keep their defaults. Throws ConfigError (file + key) on a wrong
// type, an out-of-range size, or options that fail PinholeCameraOptions::Check.
void ReadOptions(ConfigSection& s, PinholeCameraOptions* o);

}  // namespace rumi
