#include "front/sampler.h"

#include <spdlog/spdlog.h>

namespace rumi {

const OptionSpec<SamplerOptions>& SamplerOptions::Spec() {
  using O = SamplerOptions;
  static const auto* spec = [] {
    auto* s = new OptionSpec<O>("sampler");
    s->Number("inter", &O::inter, AtLeast(1), AtMost(10000), "sparse stride (frames), S1 and S3");
    s->Number("len", &O::len, AtLeast(0), AtMost(10000), "S1 samples kept before a loss");
    s->Number("th_s3", &O::th_s3, AtLeast(0), AtMost(100000),
              "S3 ends when the front submap holds more than this many frames");
    s->Enum("th_s3_unit", &O::th_s3_unit, {{"keyframes", S3Unit::kKeyframes}, {"frames", S3Unit::kFrames}},
            "what th_s3 counts");
    s->Number("max_s2", &O::max_s2, AtLeast(2), AtMost(100000), "cap on S2 samples per window (then thinned)");
    s->Number("startup_frames", &O::startup_frames, AtLeast(0), AtMost(1000000),
              "a first map that took more frames than this ships them to the back; 0: never");
    s->Number("pre_loss", &O::pre_loss, AtLeast(0), AtMost(10000), "tracked frames before a loss added to the window");
    s->Flag("clone_images", &O::clone_images, "copy sampled images (false: shallow references)");
    return s;
  }();
  return *spec;
}

bool SamplerOptions::Check(std::string* why) const { return Spec().Check(*this, why); }

const char* ToString(Sampler::Phase p) {
  switch (p) {
    case Sampler::Phase::kIdle: return "idle";
    case Sampler::Phase::kS1: return "S1";
    case Sampler::Phase::kS2: return "S2";
    case Sampler::Phase::kS3: return "S3";
  }
  return "?";
}

Sampler::Sampler(const SamplerOptions& options, const PinholeCameraOptions& camera, int64_t first_window_id)
    : o_(options), camera_(camera), first_window_id_(first_window_id), next_window_id_(first_window_id) {
  std::string why;
  if (!o_.Check(&why)) throw std::invalid_argument("SamplerOptions: " + why);
}

void Sampler::Take(const SamplerFrame& f, SampleSet set, std::vector<WindowFrame>* into) {
  WindowFrame w;
  w.timestamp = f.timestamp;
  w.image = o_.clone_images ? f.image.clone() : f.image;
  w.front_state = f.state;
  w.set = set;
  w.front_submap_id = f.submap_id;
  if (into) {
    into->push_back(std::move(w));
  } else {
    s1_.push_back(std::move(w));
    while (static_cast<int>(s1_.size()) > o_.len) s1_.pop_front();
  }
}

void Sampler::Recycle(cv::Mat* image) {
  // Only our own clones: a shallow ref still belongs to the frame source.
  if (o_.clone_images && !image->empty()) spare_.push_back(std::move(*image));
  image->release();
}

void Sampler::HoldTail(const SamplerFrame& f) {
  if (o_.pre_loss == 0) return;
  if (static_cast<int>(tail_.size()) >= o_.pre_loss) {
    Recycle(&tail_.front().image);
    tail_.pop_front();
  }
  WindowFrame w;
  w.timestamp = f.timestamp;
  if (o_.clone_images) {
    if (!spare_.empty()) {
      w.image = std::move(spare_.back());
      spare_.pop_back();
    }
    f.image.copyTo(w.image);  // reuses the buffer when the size matches
  } else {
    w.image = f.image;
  }
  w.front_state = f.state;
  w.front_submap_id = f.submap_id;
  tail_.push_back(std::move(w));
}

void Sampler::ShipTail(SampleSet set) {
  // Appended after the ring's trim: the tail does not push S1 samples out.
  for (WindowFrame& w : tail_) {
    w.set = set;
    if (set == SampleSet::kS1) {
      s1_.push_back(std::move(w));
    } else {
      body_.push_back(std::move(w));
    }
  }
  if (!tail_.empty())
    spdlog::debug("sampler: {} tracked frames before the loss join the window", tail_.size());
  tail_.clear();
}

void Sampler::ThinS2() {
  // Keep S2 samples whose loss position is a multiple of the doubled stride;
  // S3 samples (from an earlier resume in this window) all stay.
  s2_stride_ *= 2;
  std::vector<WindowFrame> kept;
  std::vector<int64_t> kept_pos;
  size_t j = 0;
  s2_count_ = 0;
  for (WindowFrame& f : body_) {
    if (f.set == SampleSet::kS2) {
      const int64_t pos = s2_pos_[j++];
      if (pos % s2_stride_ != 0) continue;
      kept_pos.push_back(pos);
      ++s2_count_;
    }
    kept.push_back(std::move(f));
  }
  body_ = std::move(kept);
  s2_pos_ = std::move(kept_pos);
  spdlog::debug("sampler: S2 cap {} reached, stride now {} ({} S2 samples kept)", o_.max_s2, s2_stride_,
                s2_count_);
}

void Sampler::StartS3(const SamplerFrame& f) {
  phase_ = Phase::kS3;
  sparse_k_ = 0;
  resume_submap_ = f.submap_id;
  tracked_since_resume_ = 0;
  keyframes_at_resume_ = f.submap_keyframes;
}

const char* Sampler::SampleDense(const SamplerFrame& f) {
  const int64_t pos = lost_k_++;
  if (pos % s2_stride_ != 0) return "skip (S2 thinned)";
  Take(f, SampleSet::kS2, &body_);
  s2_pos_.push_back(pos);
  ++s2_count_;
  if (s2_count_ >= o_.max_s2) ThinS2();
  return "sample S2";
}

void Sampler::DropPending() {
  body_.clear();
  s2_pos_.clear();
  lost_k_ = 0;
  s2_stride_ = 1;
  s2_count_ = 0;
}

void Sampler::Emit(ImageWindow* window) {
  window->id = next_window_id_++;
  window->camera = camera_;
  window->frames.clear();
  window->frames.reserve(s1_.size() + body_.size());
  for (WindowFrame& f : s1_) window->frames.push_back(std::move(f));
  for (WindowFrame& f : body_) window->frames.push_back(std::move(f));
  s1_.clear();
  DropPending();
  int n[4] = {0, 0, 0, 0};
  for (const WindowFrame& f : window->frames) ++n[static_cast<int>(f.set)];
  spdlog::debug("sampler: emit window {}: {} frames (S1 {}, S2 {}, S3 {}), {} .. {}", window->id,
                window->frames.size(), n[1], n[2], n[3],
                window->frames.empty() ? 0 : window->frames.front().timestamp,
                window->frames.empty() ? 0 : window->frames.back().timestamp);
  // The S3 samples of this window seed the next window's S1 ring.
  for (const WindowFrame& f : window->frames) {
    if (f.set != SampleSet::kS3) continue;
    WindowFrame c = f;  // shallow: shares the pixels with the emitted window
    c.set = SampleSet::kS1;
    s1_.push_back(std::move(c));
    while (static_cast<int>(s1_.size()) > o_.len) s1_.pop_front();
  }
}

bool Sampler::AddFrame(const SamplerFrame& f, ImageWindow* window) {
  const bool tracked = f.state == TrackingState::kTracking;
  bool emitted = false;
  const char* decision = "skip";

  if (!tracked) {
    if (phase_ == Phase::kIdle) {
      decision = o_.startup_frames > 0 ? SampleDense(f) : "skip (not tracked yet)";
    } else {
      if (phase_ == Phase::kS1 || phase_ == Phase::kS3) ShipTail(phase_ == Phase::kS1 ? SampleSet::kS1 : SampleSet::kS3);
      if (phase_ == Phase::kS1) {
        submap_before_loss_ = f.submap_id;
        spdlog::debug("sampler: t={} tracking lost in submap {}, dense sampling (S2)", f.timestamp,
                      f.submap_id);
      } else if (phase_ == Phase::kS3) {
        spdlog::debug("sampler: t={} lost again during S3, window extends", f.timestamp);
      }
      phase_ = Phase::kS2;
      decision = SampleDense(f);
    }
  } else {
    switch (phase_) {
      case Phase::kIdle:
        sparse_k_ = 0;
        if (StartupIsLong()) {
          // The start itself was hard: ship it, closed by S3 like a loss.
          spdlog::info("sampler: the front needed {} frames to start; they go to the back", lost_k_);
          submap_before_loss_ = -1;
          StartS3(f);
        } else {
          DropPending();
          phase_ = Phase::kS1;
        }
        break;
      case Phase::kS2:
        StartS3(f);
        spdlog::debug("sampler: t={} tracking resumed in submap {} ({} frames), S3", f.timestamp, f.submap_id,
                      f.submap_frames);
        break;
      default:
        break;
    }
    if (phase_ == Phase::kS3) {
      ++tracked_since_resume_;
      if (f.submap_id != resume_submap_) {  // front switched submap again while tracking
        resume_submap_ = f.submap_id;
        tracked_since_resume_ = 1;
        keyframes_at_resume_ = f.submap_keyframes;
      }
      const bool same = f.submap_id == submap_before_loss_;
      const int64_t count =
          o_.th_s3_unit == S3Unit::kFrames ? (same ? tracked_since_resume_ : f.submap_frames)
                                           : (same ? f.submap_keyframes - keyframes_at_resume_ : f.submap_keyframes);
      if (count > o_.th_s3) {
        Emit(window);
        emitted = true;
        phase_ = Phase::kS1;
        spdlog::debug("sampler: t={} submap {} holds {} > th_s3 {} {}: window {} done, back activated",
                      f.timestamp, f.submap_id, count, o_.th_s3,
                      o_.th_s3_unit == S3Unit::kFrames ? "frames" : "keyframes", window->id);
      }
    }
    const bool sample = sparse_k_ % o_.inter == 0;
    ++sparse_k_;
    if (!sample) {
      HoldTail(f);
    } else {
      for (WindowFrame& w : tail_) Recycle(&w.image);
      tail_.clear();
      if (phase_ == Phase::kS3) {
        Take(f, SampleSet::kS3, &body_);
        decision = "sample S3";
      } else {
        Take(f, SampleSet::kS1, nullptr);
        decision = "sample S1";
      }
    }
  }
  spdlog::debug("sampler: t={} state={} submap={} n={} phase={} -> {}", f.timestamp, ToString(f.state),
                f.submap_id, f.submap_frames, ToString(phase_), decision);
  return emitted;
}

bool Sampler::Flush(ImageWindow* window) {
  const bool has_s2 = s2_count_ > 0 && (phase_ != Phase::kIdle || StartupIsLong());
  if (!has_s2) {
    spdlog::debug("sampler: end of stream, nothing to flush (phase {})", ToString(phase_));
    return false;
  }
  spdlog::debug("sampler: end of stream in phase {}, flushing pending window", ToString(phase_));
  Emit(window);
  phase_ = Phase::kS1;
  return true;
}

}  // namespace rumi
