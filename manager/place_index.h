#pragma once
// Place recognition over every keyframe of the map: a bag of binary words
// and an inverted index, as DBoW2 gives ORB-SLAM (DBoW is not packaged in
// Debian 12, so this is our own, smaller one). The vocabulary is a tree of
// k-majority clusters of ORB descriptors, trained once from the session's
// own keyframes (a seeded, deterministic clustering): a word is a leaf, its
// weight the leaf's idf over the training set. A keyframe's vector is its
// words' tf-idf, L1-normalised; two keyframes score 1 - |v - w|_1 / 2 (1: the
// same words in the same proportions, 0: no word in common). A query walks
// only the posting lists of its own words, so its cost follows the words
// shared with the map, not the number of keyframes (docs/manager.md, "Loop
// closure", has the figures at 1k and 10k keyframes).
#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/submap.h"

namespace rumi {

struct PlaceIndexOptions {
  int branching = 10;  // k of the k-majority tree
  int levels = 4;      // depth: up to branching^levels words
  int kmajority_iterations = 8;
  // The vocabulary is trained once this many descriptors were added
  // (keyframes before it are indexed then); and from at most
  // max_train_descriptors of them, sampled evenly.
  int min_train_descriptors = 20000;
  int max_train_descriptors = 100000;
  uint32_t seed = 1;
};

// Bag of words: (word, weight) sorted by word, weights summing to 1.
using BowVector = std::vector<std::pair<int, float>>;

class PlaceVocabulary {
 public:
  // descriptors: packed 32-byte rows.
  void Train(const std::vector<uint8_t>& descriptors, const PlaceIndexOptions& o);
  bool trained() const { return !nodes_.empty(); }
  int num_words() const { return num_words_; }
  int Word(const uint8_t* descriptor) const;
  BowVector Transform(const std::vector<uint8_t>& descriptors) const;

 private:
  struct Node {
    uint8_t centre[32];
    int first_child = -1, num_children = 0;
    int word = -1;  // leaves only
  };
  std::vector<Node> nodes_;  // nodes_[0]: the root
  std::vector<float> idf_;   // per word
  int num_words_ = 0;
};

// Descriptors of a keyframe as packed 32-byte rows: its keypoints' ORB rows
// (all-zero rows, keypoints without one, left out).
std::vector<uint8_t> KeyframeDescriptors(const Keyframe& kf);

// L1 score of two normalised vectors, in [0, 1].
double BowScore(const BowVector& a, const BowVector& b);

class PlaceIndex {
 public:
  explicit PlaceIndex(const PlaceIndexOptions& o = {}) : o_(o) {}

  // Adds a keyframe by its descriptors; `key` is the caller's handle for it
  // (returned by Query; a key added before is left as it is). Before the
  // vocabulary is trained the descriptors are kept; the keyframe is indexed
  // when it is.
  void Add(int64_t key, const std::vector<uint8_t>& descriptors);
  bool ready() const { return vocabulary_.trained(); }
  bool Contains(int64_t key) const { return slot_of_.count(key) > 0; }
  size_t size() const { return keys_.size() - num_dead_; }
  const PlaceVocabulary& vocabulary() const { return vocabulary_; }
  // Trains now on what was added (tests, and a map loaded whole).
  void TrainNow();
  // Takes a keyframe out (culled, or its submap gone): the index follows
  // the map, not the session. Postings are compacted once the removed
  // outnumber the living.
  void Remove(int64_t key);
  template <typename Keep>
  void RemoveUnless(Keep keep) {
    std::vector<int64_t> gone;
    for (const auto& [key, slot] : slot_of_)
      if (!keep(key)) gone.push_back(key);
    for (int64_t key : gone) Remove(key);
  }

  // The keyframe's bag of words (empty before training).
  const BowVector& Bow(int64_t key) const;

  struct Match {
    int64_t key;
    double score;
  };
  // The keyframes sharing words with `query`, best score first, at most
  // max_results, without those `skip` refuses. Empty before training.
  template <typename Skip>
  std::vector<Match> Query(const BowVector& query, size_t max_results, Skip skip) const;
  std::vector<Match> Query(const BowVector& query, size_t max_results) const {
    return Query(query, max_results, [](int64_t) { return false; });
  }
  // Postings the last Query walked (its cost).
  size_t last_postings() const { return last_postings_; }

 private:
  void Index(size_t slot);
  // Every keyframe sharing a word with the query, with its score (unsorted).
  std::vector<Match> Score(const BowVector& query) const;

  PlaceIndexOptions o_;
  PlaceVocabulary vocabulary_;
  void Compact();

  std::vector<int64_t> keys_;
  std::vector<BowVector> bows_;
  std::vector<char> dead_;
  size_t num_dead_ = 0;
  std::vector<std::vector<uint8_t>> pending_;  // descriptors until training
  size_t pending_descriptors_ = 0;
  std::vector<std::vector<std::pair<int, float>>> postings_;  // word -> (slot, weight)
  std::unordered_map<int64_t, size_t> slot_of_;
  // Query scratch (a query is not thread-safe): score per slot, and the
  // slots touched.
  mutable std::vector<float> acc_;
  mutable std::vector<int> touched_;
  mutable size_t last_postings_ = 0;
};

template <typename Skip>
std::vector<PlaceIndex::Match> PlaceIndex::Query(const BowVector& query, size_t max_results, Skip skip) const {
  std::vector<Match> m = Score(query);
  m.erase(std::remove_if(m.begin(), m.end(), [&](const Match& x) { return skip(x.key); }), m.end());
  const auto better = [](const Match& a, const Match& b) { return a.score != b.score ? a.score > b.score : a.key < b.key; };
  if (m.size() > max_results) {
    std::partial_sort(m.begin(), m.begin() + long(max_results), m.end(), better);
    m.resize(max_results);
  } else {
    std::sort(m.begin(), m.end(), better);
  }
  return m;
}

}  // namespace rumi
