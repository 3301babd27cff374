#include "ipc/link/latency_plot.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace rumi {

bool ReadLinkFramesLog(const std::string& path, std::vector<LinkFrameLogLine>* out, std::string* why) {
  std::ifstream in(path);
  if (!in) {
    if (why) *why = path + ": cannot read";
    return false;
  }
  std::string line;
  int n = 0;
  out->clear();
  while (std::getline(in, line)) {
    ++n;
    if (n == 1 && line.rfind("frame_id,", 0) == 0) continue;  // header
    if (line.empty()) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    LinkFrameLogLine r;
    try {
      if (f.size() != 9) throw std::runtime_error("9 fields expected");
      r.frame_id = static_cast<uint32_t>(std::stoul(f[0]));
      r.latency_ms = std::stod(f[5]);
      r.fragments = std::stoi(f[6]);
      r.recovered = std::stoi(f[7]);
      if (f[8] != "complete" && f[8] != "dropped") throw std::runtime_error("status '" + f[8] + "'");
      r.dropped = f[8] == "dropped";
    } catch (const std::exception& e) {
      if (why) *why = path + ":" + std::to_string(n) + ": not a frames-log line (" + e.what() + ")";
      return false;
    }
    out->push_back(r);
  }
  return true;
}

cv::Mat RenderLatencyPlot(const std::vector<LinkFrameLogLine>& frames, const std::string& title, int width,
                          int height) {
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 70, right = 20, top = 40, bottom = 50;
  const int pw = width - left - right, ph = height - top - bottom;
  std::vector<double> lat;
  int dropped = 0, recovered = 0;
  for (const auto& f : frames) {
    if (f.dropped) ++dropped;
    else lat.push_back(f.latency_ms), recovered += f.recovered > 0;
  }
  std::vector<double> sorted = lat;
  std::sort(sorted.begin(), sorted.end());
  auto pct = [&](double q) { return sorted.empty() ? 0.0 : sorted[static_cast<size_t>(q * (sorted.size() - 1))]; };
  const double ymax = std::max(50.0, (sorted.empty() ? 0.0 : sorted.back()) * 1.1);
  const cv::Scalar axis(60, 60, 60), grid(225, 225, 225), blue(200, 110, 30), orange(0, 140, 255), red(40, 40, 220);
  for (int k = 0; k <= 5; ++k) {  // y grid and labels
    const int y = top + ph - static_cast<int>(ph * k / 5.0);
    cv::line(img, {left, y}, {left + pw, y}, grid, 1);
    char b[32];
    std::snprintf(b, sizeof(b), "%.0f", ymax * k / 5.0);
    cv::putText(img, b, {5, y + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, axis, 1, cv::LINE_AA);
  }
  cv::rectangle(img, {left, top}, {left + pw, top + ph}, axis, 1);
  const size_t n = std::max<size_t>(1, frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    const int x = left + static_cast<int>(pw * (i + 0.5) / n);
    if (frames[i].dropped) {
      cv::line(img, {x, top + ph}, {x, top + ph - 12}, red, 2);
      continue;
    }
    const int y = top + ph - static_cast<int>(ph * std::min(1.0, frames[i].latency_ms / ymax));
    cv::circle(img, {x, y}, 2, frames[i].recovered ? orange : blue, cv::FILLED, cv::LINE_AA);
  }
  char caption[256];
  std::snprintf(caption, sizeof(caption),
                "%s   %zu frames, %d dropped (red), %d complete after a retransmission (orange); latency ms p50 %.0f "
                "p95 %.0f max %.0f",
                title.c_str(), frames.size(), dropped, recovered, pct(0.5), pct(0.95),
                sorted.empty() ? 0.0 : sorted.back());
  cv::putText(img, caption, {left, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.5, axis, 1, cv::LINE_AA);
  cv::putText(img, "frame (arrival order)", {left + pw / 2 - 80, height - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.5, axis, 1,
              cv::LINE_AA);
  cv::putText(img, "ms", {5, top - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, axis, 1, cv::LINE_AA);
  return img;
}

}  // namespace rumi
