#include "rgbdmap/loop/binary_words.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace rgbdmap {

BinaryWordHasher::BinaryWordHasher(const BinaryWordsConfig& config)
    : tables_(std::max(1, config.tables)), bits_(std::clamp(config.bits_per_word, 1, 20)) {
  std::mt19937 rng(config.seed);
  std::vector<uint16_t> all(256);
  std::iota(all.begin(), all.end(), uint16_t{0});
  for (int t = 0; t < tables_; ++t) {
    std::shuffle(all.begin(), all.end(), rng);  // distinct positions within a table
    bit_index_.insert(bit_index_.end(), all.begin(), all.begin() + bits_);
  }
}

WordHistogram BinaryWordHasher::histogram(const cv::Mat& descriptors) const {
  std::vector<uint32_t> words;
  if (descriptors.empty() || descriptors.type() != CV_8U || descriptors.cols != 32) return {};
  words.reserve(static_cast<size_t>(descriptors.rows) * tables_);
  for (int r = 0; r < descriptors.rows; ++r) {
    const uint8_t* d = descriptors.ptr<uint8_t>(r);
    for (int t = 0; t < tables_; ++t) {
      uint32_t code = 0;
      const uint16_t* pos = &bit_index_[static_cast<size_t>(t) * bits_];
      for (int b = 0; b < bits_; ++b) code = (code << 1) | ((d[pos[b] >> 3] >> (pos[b] & 7)) & 1u);
      words.push_back((static_cast<uint32_t>(t) << bits_) | code);
    }
  }
  std::sort(words.begin(), words.end());
  WordHistogram hist;
  for (uint32_t w : words) {
    if (!hist.empty() && hist.back().first == w && hist.back().second < UINT16_MAX)
      ++hist.back().second;
    else if (hist.empty() || hist.back().first != w)
      hist.emplace_back(w, uint16_t{1});
  }
  return hist;
}

BinaryWordIndex::BinaryWordIndex(const BinaryWordsConfig& config)
    : config_(config), postings_(BinaryWordHasher(config).wordCount()) {}

void BinaryWordIndex::insert(int keyframe_id, int robot_id, int robot_sequence, const WordHistogram& words) {
  const auto doc = static_cast<uint32_t>(docs_.size());
  docs_.push_back({keyframe_id, robot_id, robot_sequence});
  for (const auto& [word, count] : words)
    if (word < postings_.size()) postings_[word].push_back({doc, count});
}

bool BinaryWordIndex::excluded(const Doc& d, const RetrievalQuery& q) const {
  return d.robot_id == q.robot_id && d.robot_sequence > q.robot_sequence - q.exclude_recent;
}

double BinaryWordIndex::idf(uint32_t word, bool* stop) const {
  const double n_docs = static_cast<double>(docs_.size());
  const double df = word < postings_.size() ? static_cast<double>(postings_[word].size()) : 0.0;
  *stop = df == 0.0 || df > std::max(1.0, config_.stop_word_fraction * n_docs);
  return std::log((n_docs + 1.0) / (df + 1.0));
}

std::vector<RetrievalHit> BinaryWordIndex::query(const WordHistogram& words, const RetrievalQuery& q) const {
  if (docs_.empty() || q.top_n <= 0) return {};
  std::vector<float> score(docs_.size(), 0.0f);
  double query_mass = 0.0;
  for (const auto& [word, count] : words) {
    bool stop = false;
    const double w = idf(word, &stop);
    query_mass += w * count;
    if (stop) continue;
    for (const Posting& p : postings_[word]) score[p.doc] += static_cast<float>(w * std::min(count, p.count));
  }
  std::vector<RetrievalHit> hits;
  if (query_mass <= 0.0) return hits;
  for (size_t i = 0; i < docs_.size(); ++i) {
    const double s = score[i] / query_mass;
    if (score[i] <= 0.0f || s < q.min_score || excluded(docs_[i], q)) continue;
    hits.push_back({docs_[i].keyframe_id, docs_[i].robot_id, s});
  }
  const size_t n = std::min(hits.size(), static_cast<size_t>(q.top_n));
  std::partial_sort(hits.begin(), hits.begin() + static_cast<long>(n), hits.end(),
                    [](const RetrievalHit& a, const RetrievalHit& b) { return a.score > b.score; });
  hits.resize(n);
  return hits;
}

}  // namespace rgbdmap
