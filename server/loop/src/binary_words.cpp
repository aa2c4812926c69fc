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

namespace {

void putVarint(uint32_t v, std::vector<uint8_t>* out) {
  while (v >= 0x80) {
    out->push_back(static_cast<uint8_t>(v | 0x80));
    v >>= 7;
  }
  out->push_back(static_cast<uint8_t>(v));
}

/// Reads a varint written by putVarint (the lists are written here only, so they are well formed).
uint32_t getVarint(const uint8_t*& p) {
  uint32_t v = 0;
  for (int shift = 0;; shift += 7) {
    const uint8_t b = *p++;
    v |= static_cast<uint32_t>(b & 0x7f) << shift;
    if (!(b & 0x80)) return v;
  }
}

}  // namespace

void BinaryWordIndex::insert(int keyframe_id, int robot_id, int robot_sequence, const WordHistogram& words) {
  const auto doc = static_cast<uint32_t>(docs_.size());
  docs_.push_back({keyframe_id, robot_id, robot_sequence});
  for (const auto& [word, count] : words) {
    if (word >= postings_.size() || count == 0) continue;
    PostingList& list = postings_[word];
    const size_t capacity = list.bytes.capacity();
    // Gaps from the previous document (the first: from 0); < 2^31 while there are fewer documents.
    const uint32_t gap = list.df == 0 ? doc : doc - list.last_doc;
    putVarint(gap << 1 | (count > 1 ? 1u : 0u), &list.bytes);
    if (count > 1) putVarint(count, &list.bytes);
    list.last_doc = doc;
    ++list.df;
    ++postings_count_;
    list_bytes_ += list.bytes.capacity() - capacity;
  }
}

size_t BinaryWordIndex::memoryBytes() const {
  return postings_.capacity() * sizeof(PostingList) + docs_.capacity() * sizeof(Doc) + list_bytes_;
}

bool BinaryWordIndex::excluded(const Doc& d, const RetrievalQuery& q) const {
  return d.robot_id == q.robot_id && d.robot_sequence > q.robot_sequence - q.exclude_recent;
}

double BinaryWordIndex::idf(uint32_t word, bool* stop) const {
  const double n_docs = static_cast<double>(docs_.size());
  const double df = word < postings_.size() ? static_cast<double>(postings_[word].df) : 0.0;
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
    const PostingList& list = postings_[word];
    const uint8_t* p = list.bytes.data();
    uint32_t doc = 0;
    for (uint32_t i = 0; i < list.df; ++i) {
      const uint32_t head = getVarint(p);
      doc += head >> 1;
      const uint32_t doc_count = (head & 1u) ? getVarint(p) : 1u;
      score[doc] += static_cast<float>(w * std::min<uint32_t>(count, doc_count));
    }
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
