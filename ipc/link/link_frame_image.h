#pragma once
// A reassembled link frame as a grey image: JPEG decoded by OpenCV, or raw
// grey pixels. One decoder for every user of the link (the front's link
// source, `rumi calibrate --link`).
#include <opencv2/core.hpp>

#include "ipc/link/frame_reassembler.h"

namespace rumi {

// CV_8UC1; empty when the bytes do not decode, the format is unknown, or raw
// grey bytes do not match the frame's size. Never throws.
cv::Mat DecodeLinkFrame(const LinkFrame& frame);

}  // namespace rumi
