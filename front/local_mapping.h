#pragma once
// Local mapping: consumes new keyframes from tracking, links them into the
// covisibility graph, culls young points, triangulates new points with
// neighbour keyframes, fuses duplicates, runs local BA (Ceres; outer
// keyframes fixed) and culls redundant keyframes. Runs in its own thread, or
// inline (Step()) for deterministic tests. Map access is in short locked
// steps; BA is solved on a copy without the lock.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "front/front_options.h"
#include "front/map.h"

namespace rumi {

class LocalMapper {
 public:
  LocalMapper(Map* map, const PinholeCamera& cam, const ScalePyramid& pyr, const FrontOptions& o);
  ~LocalMapper();
  void Start();           // starts the thread (no-op when inline)
  void Stop();            // aborts current work and joins
  void Push(KeyFrame* kf);
  bool Idle() const { return idle_.load() && QueueSize() == 0; }
  size_t QueueSize() const;
  // Inline mode: processes everything queued.
  void Drain();
  int64_t processed() const { return processed_.load(); }

 private:
  void Run();
  void Process(KeyFrame* kf);
  void CullPoints(KeyFrame* kf);
  void Triangulate(KeyFrame* kf);
  void FuseNeighbours(KeyFrame* kf);
  void CullKeyFrames(KeyFrame* kf);

  Map* map_;
  PinholeCamera cam_;
  ScalePyramid pyr_;
  FrontOptions o_;
  mutable std::mutex qm_;
  std::condition_variable cv_;
  std::deque<KeyFrame*> queue_;
  std::vector<Landmark*> recent_;
  std::thread thread_;
  std::atomic<bool> stop_{false}, abort_ba_{false}, idle_{true};
  std::atomic<int64_t> processed_{0};
  int ba_skipped_ = 0;  // consecutive keyframes processed without local BA
};

}  // namespace rumi
