#include "back/window_dir.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace rumi {

bool ReadWindowDir(const std::string& dir, const PinholeCameraOptions& camera,
                   const WindowDirOptions& o, int64_t window_id, ImageWindow* window,
                   std::string* error) {
  auto fail = [error](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (o.first < 0 || o.step < 1 || !(o.scale > 0)) return fail("bad window subset options");
  const std::filesystem::path index = std::filesystem::path(dir) / o.index_file;
  std::ifstream in(index);
  if (!in) return fail(index.string() + ": cannot open");
  ImageWindow w;
  w.id = window_id;
  w.camera = camera;
  if (o.scale != 1.0) {
    // Pixel centres at integers: a scaled pixel x maps to (x + 0.5) * s - 0.5.
    w.camera.width = static_cast<int>(std::lround(camera.width * o.scale));
    w.camera.height = static_cast<int>(std::lround(camera.height * o.scale));
    w.camera.fx = camera.fx * o.scale;
    w.camera.fy = camera.fy * o.scale;
    w.camera.cx = (camera.cx + 0.5) * o.scale - 0.5;
    w.camera.cy = (camera.cy + 0.5) * o.scale - 0.5;
  }
  std::string line;
  int line_no = 0, listed = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ls(line);
    std::string ts_text, path, set_text;
    if (!(ls >> ts_text >> path))
      return fail(index.string() + ":" + std::to_string(line_no) + ": expected '<seconds> <path> [set]'");
    SampleSet set = SampleSet::kS2;  // no set given: a lost stretch of its own
    if ((ls >> set_text) && !ParseSampleSet(set_text, &set))
      return fail(index.string() + ":" + std::to_string(line_no) + ": set must be 1, 2, 3 (or S1..S3), got '" +
                  set_text + "'");
    Timestamp t = 0;
    if (!ParseSecondsToNs(ts_text, &t))
      return fail(index.string() + ":" + std::to_string(line_no) + ": bad timestamp '" + ts_text + "'");
    const int k = listed++;
    if (k < o.first || (k - o.first) % o.step != 0) continue;
    if (o.count >= 0 && static_cast<int>(w.frames.size()) >= o.count) break;
    const std::filesystem::path p =
        std::filesystem::path(path).is_absolute() ? std::filesystem::path(path)
                                                  : std::filesystem::path(dir) / path;
    WindowFrame f;
    f.timestamp = t;
    f.set = set;
    f.front_state = set == SampleSet::kS2 ? TrackingState::kLost : TrackingState::kTracking;
    f.image = cv::imread(p.string(), cv::IMREAD_GRAYSCALE);
    if (f.image.empty()) return fail(p.string() + ": cannot read image");
    if (f.image.cols != camera.width || f.image.rows != camera.height)
      return fail(p.string() + ": image is " + std::to_string(f.image.cols) + "x" +
                  std::to_string(f.image.rows) + ", camera is " + std::to_string(camera.width) +
                  "x" + std::to_string(camera.height));
    if (o.scale != 1.0) {
      cv::Mat scaled;
      cv::resize(f.image, scaled, cv::Size(w.camera.width, w.camera.height), 0, 0, cv::INTER_AREA);
      f.image = scaled;
    }
    w.frames.push_back(std::move(f));
  }
  if (w.frames.empty()) return fail(index.string() + ": no frames selected");
  *window = std::move(w);
  return true;
}

}  // namespace rumi
