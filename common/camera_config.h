#pragma once
// The `camera:` section of a rumi config (PinholeCameraOptions::Spec):
//   camera: {width: 640, height: 480, fx: .., fy: .., cx: .., cy: ..,
//            k1: 0, k2: 0, p1: 0, p2: 0, k3: 0, flipped_y: false}
// ReadOptions(section, &camera) reads it (common/option_spec.h); absent keys
// keep their defaults.
#include "common/camera.h"
#include "common/option_spec.h"
