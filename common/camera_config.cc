#include "common/camera_config.h"

namespace rumi {

void ReadOptions(ConfigSection& s, PinholeCameraOptions* o) {
  s.ReadInRange("width", &o->width, 1, 100000);
  s.ReadInRange("height", &o->height, 1, 100000);
  s.Read("fx", &o->fx);
  s.Read("fy", &o->fy);
  s.Read("cx", &o->cx);
  s.Read("cy", &o->cy);
  s.Read("k1", &o->k1);
  s.Read("k2", &o->k2);
  s.Read("p1", &o->p1);
  s.Read("p2", &o->p2);
  s.Read("k3", &o->k3);
  std::string why;
  if (!o->Check(&why)) {
    std::string section = s.FullKey("");
    if (!section.empty() && section.back() == '.') section.pop_back();
    throw ConfigError(s.file() + ": section '" + (section.empty() ? "camera" : section) + "': " + why);
  }
}

}  // namespace rumi
