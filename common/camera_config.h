#pragma once
// The `camera:` section of a rumi config (PinholeCameraOptions::Spec):
//   camera: {width: 640, height: 480, fx: .., fy: .., cx: .., cy: ..,
//            k1: 0, k2: 0, p1: 0, p2: 0, k3: 0, flipped_y: false}
// ReadOptions(section, &camera) reads it (common/option_spec.h); absent keys
// keep their defaults.
#include <string>

#include "common/camera.h"
#include "common/option_spec.h"

namespace rumi {

// The section as YAML text ("camera:\n  width: 640\n  ..."), every key of
// the spec with 12 significant digits: ReadOptions reads it back (`rumi
// calibrate` writes it).
std::string CameraSectionYaml(const PinholeCameraOptions& camera);

}  // namespace rumi
