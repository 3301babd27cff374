#pragma once
// source.kind: link — frames from the robot over the robot link (ipc/link,
// docs/robot_link.md) as a FrameStream.
#include <memory>

#include "common/camera.h"
#include "front/frame_stream.h"
#include "ipc/link/link_options.h"

namespace rumi {

// Binds the link's UDP socket; throws StreamError naming the address when it
// cannot.
std::unique_ptr<FrameStream> OpenLinkStream(const LinkOptions& o, const PinholeCameraOptions& camera);

}  // namespace rumi
