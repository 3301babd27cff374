#include "ipc/link/link_frame_image.h"

#include <opencv2/imgcodecs.hpp>

#include "rumi_link.h"

namespace rumi {

cv::Mat DecodeLinkFrame(const LinkFrame& f) {
  if (f.format == RL_FORMAT_JPEG) {
    try {
      return cv::imdecode(f.data, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      return cv::Mat();
    }
  }
  if (f.format == RL_FORMAT_GREY && f.width > 0 && f.height > 0 &&
      f.data.size() == static_cast<size_t>(f.width) * f.height)
    return cv::Mat(f.height, f.width, CV_8U, const_cast<uint8_t*>(f.data.data())).clone();
  return cv::Mat();
}

}  // namespace rumi
