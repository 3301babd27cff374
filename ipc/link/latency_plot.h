#pragma once
// The link's latency per frame as a PNG (like the rat-robot paper's Fig. 4):
// from the frames log (source.link.frames_log), capture -> complete latency
// of every frame in arrival order, dropped frames as red ticks.
// `rumi link-plot FRAMES_CSV`.
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace rumi {

struct LinkFrameLogLine {
  uint32_t frame_id = 0;
  double latency_ms = 0;
  int fragments = 0, recovered = 0;
  bool dropped = false;
};

// Reads a frames log; false (and *why naming the line) when it is not one.
bool ReadLinkFramesLog(const std::string& path, std::vector<LinkFrameLogLine>* out, std::string* why);

cv::Mat RenderLatencyPlot(const std::vector<LinkFrameLogLine>& frames, const std::string& title, int width = 1400,
                          int height = 420);

}  // namespace rumi
