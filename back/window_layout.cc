#include "back/window_layout.h"

#include <algorithm>

#include "back/blank_cut.h"

namespace rumi {

WindowLayout LayOutWindow(const ImageWindow& window, const BackOptions& options) {
  WindowLayout l;
  const size_t n = window.frames.size();
  l.blank.assign(n, false);
  if (options.blank_max_stddev > 0)
    for (size_t i = 0; i < n; ++i)
      l.blank[i] = IsBlankImage(window.frames[i].image, options.blank_max_stddev, options.blank_max_structure);
  l.num_blank = int(std::count(l.blank.begin(), l.blank.end(), true));
  std::vector<Timestamp> times;
  for (const WindowFrame& f : window.frames) times.push_back(f.timestamp);
  l.stretches = BlankStretches(times, l.blank, options.blank_min_frames);
  l.side.assign(n, 0);
  for (size_t i = 0; i < n; ++i)
    for (const auto& st : l.stretches) l.side[i] += window.frames[i].timestamp > st.second;
  l.part_bounds = window.joined_at;
  for (const auto& st : l.stretches) l.part_bounds.push_back(st.second + 1);
  std::sort(l.part_bounds.begin(), l.part_bounds.end());
  return l;
}

}  // namespace rumi
