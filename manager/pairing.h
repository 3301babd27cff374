#pragma once
// Pairing of back and front keyframes taken from the same image: the front
// and the back see the same input, so a shared frame shows up as keyframes
// with equal capture timestamps (|dt| < 1e-4 s). Only frames of F^search are
// used: frames the front failed on plus the first and last n keyframes of
// each back submap, where submaps meet and M_com is most likely.
#include <cstdint>
#include <vector>

#include "common/submap.h"

namespace rumi {

struct KeyframePair {
  int front_keyframe = -1;  // index into front.keyframes
  int back_keyframe = -1;   // index into back.keyframes
  int64_t dt_ns = 0;        // back - front
};

// Sorted set of timestamps compared with a tolerance.
class SearchSet {
 public:
  void Add(Timestamp t) { times_.push_back(t); sorted_ = false; }
  // True when some member t' has |t - t'| < max_dt_ns.
  bool Contains(Timestamp t, int64_t max_dt_ns) const;
  size_t size() const { return times_.size(); }
  bool all() const { return all_; }
  void set_all(bool all) { all_ = all; }

 private:
  void Sort() const;
  mutable std::vector<Timestamp> times_;
  mutable bool sorted_ = true;
  bool all_ = false;  // every timestamp is a member
};

// F^search from the per-frame states of the front and the back submaps.
// n == 0 puts every back keyframe in the set.
SearchSet BuildSearchSet(const std::vector<const Submap*>& front_submaps,
                         const std::vector<const Submap*>& back_submaps, int n);

// One-to-one pairs: each back keyframe in the search set with the front
// keyframe nearest in time when |dt| < max_dt_ns. Keyframes need not be sorted.
std::vector<KeyframePair> PairKeyframes(const Submap& front, const Submap& back,
                                        const SearchSet& search, int64_t max_dt_ns);

// A back keyframe whose image the front tracked without making it a keyframe
// (the sampler ships frames every `inter` frames, the front makes keyframes
// when it needs them, so the two rarely coincide). The front side is the
// frame's pose; its map points come from the front keyframes nearest in time.
struct FramePair {
  int front_frame = -1;    // index into front.frames (state kTracking)
  int back_keyframe = -1;  // index into back.keyframes
  int64_t dt_ns = 0;       // back - front
  std::vector<int> front_keyframes;  // indices into front.keyframes, nearest in time
};

// Back keyframes in the search set that got no keyframe pair (`taken`) are
// paired with the tracked front frame nearest in time when |dt| < max_dt_ns;
// `neighbours` front keyframes before and as many after it are attached.
std::vector<FramePair> PairTrackedFrames(const Submap& front, const Submap& back, const SearchSet& search,
                                         int64_t max_dt_ns, const std::vector<KeyframePair>& taken,
                                         int neighbours);

}  // namespace rumi
