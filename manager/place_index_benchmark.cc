// Place recognition query cost as the map grows (#51: "state the figure at
// 1k and 10k keyframes"): an index of N keyframes, 500 descriptors each,
// over N / 5 places; a query is a new view's bag of words (transform) and
// the inverted-index walk (query). Counters: postings walked per query.
//   build-*/bin/place_index_benchmark
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "manager/place_index.h"
#include "manager/testing/synthetic_places.h"

namespace rumi {
namespace {

struct Built {
  std::unique_ptr<SyntheticPlaces> places;
  std::unique_ptr<PlaceIndex> index;
  int num_places = 0;
};

Built& IndexOf(int keyframes) {
  static std::map<int, Built> cache;
  Built& b = cache[keyframes];
  if (!b.index) {
    b.num_places = keyframes / 5;
    b.places = std::make_unique<SyntheticPlaces>(b.num_places, 560, 11);
    b.index = std::make_unique<PlaceIndex>();  // default options: trains after 20k descriptors
    for (int k = 0; k < keyframes; ++k) b.index->Add(k, b.places->View(k % b.num_places, k / b.num_places, 24));
  }
  return b;
}

void BM_PlaceQuery(benchmark::State& state) {
  Built& b = IndexOf(int(state.range(0)));
  int place = 0;
  size_t postings = 0, queries = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const std::vector<uint8_t> view = b.places->View(place, 99, 24);
    state.ResumeTiming();
    const BowVector q = b.index->vocabulary().Transform(view);
    benchmark::DoNotOptimize(b.index->Query(q, 10));
    postings += b.index->last_postings();
    ++queries;
    place = (place + 1) % b.num_places;
  }
  state.counters["postings_per_query"] = double(postings) / double(std::max<size_t>(1, queries));
  state.counters["words"] = b.index->vocabulary().num_words();
}
BENCHMARK(BM_PlaceQuery)->Arg(1000)->Arg(10000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rumi

BENCHMARK_MAIN();
