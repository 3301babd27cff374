#include "common/camera_config.h"

#include <cmath>

namespace rumi {

const OptionSpec<PinholeCameraOptions>& PinholeCameraOptions::Spec() {
  using O = PinholeCameraOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("camera");
    s->Number("width", &O::width, AtLeast(1), AtMost(100000), "image width in pixels (frames must have it)");
    s->Number("height", &O::height, AtLeast(1), AtMost(100000), "image height in pixels");
    s->Number("fx", &O::fx, Unbounded<double>(), Unbounded<double>(), "focal length x, pixels (> 0)");
    s->Number("fy", &O::fy, Unbounded<double>(), Unbounded<double>(),
              "focal length y, pixels (> 0; < 0 only with flipped_y)");
    s->Number("cx", &O::cx, Unbounded<double>(), Unbounded<double>(), "principal point x, pixels (inside the image)");
    s->Number("cy", &O::cy, Unbounded<double>(), Unbounded<double>(), "principal point y, pixels (inside the image)");
    s->Number("k1", &O::k1, Unbounded<double>(), Unbounded<double>(), "radial distortion");
    s->Number("k2", &O::k2, Unbounded<double>(), Unbounded<double>(), "radial distortion");
    s->Number("p1", &O::p1, Unbounded<double>(), Unbounded<double>(), "tangential distortion");
    s->Number("p2", &O::p2, Unbounded<double>(), Unbounded<double>(), "tangential distortion");
    s->Number("k3", &O::k3, Unbounded<double>(), Unbounded<double>(), "radial distortion");
    s->Flag("flipped_y", &O::flipped_y, "the camera's y axis points up: fy is negative on purpose (ICL-NUIM)");
    s->Rule([](const O& o) -> std::string {
      if (o.fx > 0 && (o.flipped_y ? o.fy < 0 : o.fy > 0)) return "";
      return "focal lengths must be positive (fx " + std::to_string(o.fx) + ", fy " + std::to_string(o.fy) + ")" +
             (o.flipped_y ? "; with flipped_y: true, fy must be negative"
                          : (o.fx > 0 ? "; a negative fy needs flipped_y: true (a y-up camera such as ICL-NUIM's)"
                                      : ""));
    });
    s->Rule([](const O& o) -> std::string {
      if (o.cx >= 0 && o.cx <= o.width && o.cy >= 0 && o.cy <= o.height) return "";
      return "principal point (" + std::to_string(o.cx) + ", " + std::to_string(o.cy) + ") lies outside the " +
             std::to_string(o.width) + "x" + std::to_string(o.height) + " image";
    });
    return s;
  }();
  return *spec;
}

bool PinholeCameraOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

std::string CameraSectionYaml(const PinholeCameraOptions& camera) {
  std::string out = PinholeCameraOptions::Spec().section() + ":\n";
  for (const OptionInfo& o : PinholeCameraOptions::Spec().Describe(camera)) out += "  " + o.key + ": " + o.value + "\n";
  return out;
}

}  // namespace rumi
