// Window transfer over the shared-memory ring vs a plain memcpy of the same
// pixel bytes, and the front-side push latency (p50/p99) with a consumer
// draining in another thread.
//   build-ipc/ipc/ipc_benchmark   (or <build>/ipc_benchmark)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>
#include <unistd.h>
#include <vector>

#include "ipc/channels.h"
#include "ipc/test_data.h"
#include "ipc/window_codec.h"

namespace rumi {
namespace {

constexpr int kWidth = 640, kHeight = 480;

IpcOptions BenchOptions(const char* tag) {
  IpcOptions o;
  o.instance = std::string("bench") + std::to_string(getpid()) + tag;
  o.window_slots = 4;
  o.window_slot_bytes = 64 << 20;
  return o;
}

size_t PixelBytes(const ImageWindow& w) {
  size_t n = 0;
  for (const auto& f : w.frames) n += f.image.total() * f.image.elemSize();
  return n;
}

// Baseline: copy the window's pixels once into a preallocated buffer.
void BM_MemcpyWindowPixels(benchmark::State& state) {
  const ImageWindow w = ipc_test::MakeWindow(1, static_cast<int>(state.range(0)), kWidth, kHeight);
  std::vector<uint8_t> dst(PixelBytes(w));
  for (auto _ : state) {
    uint8_t* p = dst.data();
    for (const auto& f : w.frames) {
      const size_t n = f.image.total();
      std::memcpy(p, f.image.data, n);
      p += n;
    }
    benchmark::DoNotOptimize(dst.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * PixelBytes(w)));
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * w.frames.size()));
}

// Send (serialise into the slot) + receive in place (decode headers, point
// cv::Mats into the slot) + release, one thread.
void BM_WindowTransfer(benchmark::State& state) {
  const ImageWindow w = ipc_test::MakeWindow(1, static_cast<int>(state.range(0)), kWidth, kHeight);
  const IpcOptions o = BenchOptions("t");
  WindowSender tx(o);
  WindowReceiver rx(o);
  int64_t frames = 0;
  for (auto _ : state) {
    if (tx.Send(w) != PushStatus::kOk) state.SkipWithError("push dropped");
    rx.ReceiveInPlace([&](const ImageWindow& got) {
      frames += static_cast<int64_t>(got.frames.size());
      benchmark::DoNotOptimize(got.frames.back().image.data);
    });
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * PixelBytes(w)));
  state.SetItemsProcessed(frames);
}

void SetPercentiles(benchmark::State& state, std::vector<double>* us) {
  std::sort(us->begin(), us->end());
  state.counters["p50_us"] = (*us)[us->size() / 2];
  state.counters["p99_us"] = (*us)[std::min(us->size() - 1, us->size() * 99 / 100)];
  state.counters["max_us"] = us->back();
}

// Front-side push latency (serialise into a free slot) while a consumer
// thread drains in place; the producer is paced so that a slot is free, as
// with a back that keeps up. Only the Send call is timed.
void BM_PushLatencyWithConsumer(benchmark::State& state) {
  const ImageWindow w = ipc_test::MakeWindow(1, static_cast<int>(state.range(0)), kWidth, kHeight);
  const IpcOptions o = BenchOptions("l");
  WindowSender tx(o);
  std::atomic<bool> stop{false};
  std::atomic<int64_t> consumed{0};
  std::thread consumer([&] {
    WindowReceiver rx(o);
    while (!stop.load()) {
      if (rx.ReceiveInPlace([](const ImageWindow&) {}, 0.001) == PopStatus::kOk) ++consumed;
    }
  });
  std::vector<double> us;
  int64_t pushed = 0, dropped = 0;
  for (auto _ : state) {
    while (pushed - consumed.load() >= o.window_slots) std::this_thread::yield();
    const auto t0 = std::chrono::steady_clock::now();
    const PushStatus st = tx.Send(w);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(dt);
    us.push_back(dt * 1e6);
    if (st == PushStatus::kOk) {
      ++pushed;
    } else {
      ++dropped;
    }
  }
  stop = true;
  consumer.join();
  SetPercentiles(state, &us);
  state.counters["dropped"] = static_cast<double>(dropped);
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * PixelBytes(w)));
}

// Push against a full ring with no consumer: the drop path (what the front
// pays while the back is dead or busy).
void BM_PushLatencyRingFull(benchmark::State& state) {
  const ImageWindow w = ipc_test::MakeWindow(1, static_cast<int>(state.range(0)), kWidth, kHeight);
  const IpcOptions o = BenchOptions("f");
  WindowSender tx(o);
  for (int i = 0; i < o.window_slots; ++i) tx.Send(w);
  std::vector<double> us;
  int64_t dropped = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    dropped += tx.Send(w) == PushStatus::kDropped;
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  SetPercentiles(state, &us);
  state.counters["dropped"] = static_cast<double>(dropped);
}

BENCHMARK(BM_MemcpyWindowPixels)->Arg(1)->Arg(10)->Arg(30);
BENCHMARK(BM_WindowTransfer)->Arg(1)->Arg(10)->Arg(30);
BENCHMARK(BM_PushLatencyWithConsumer)->Arg(1)->Arg(10)->Iterations(1000)->UseManualTime();
BENCHMARK(BM_PushLatencyRingFull)->Arg(10)->Iterations(10000);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
