#pragma once
// Appearance retrieval without a trained vocabulary: a fixed, data-independent bag of binary words.
//
// Choice: bit-sampling LSH. Each of `tables` hash tables reads `bits_per_word` fixed, seeded bit positions
// of a 256-bit ORB descriptor; the bits form a word id (table * 2^bits + code). Two descriptors at Hamming
// distance d share a table's word with probability (1 - d/256)^bits: ~0.14 for a true match (d ~ 30) at 16
// bits, 2^-16 for unrelated descriptors (d ~ 128). 16 bits keep the table sparse: a keyframe of 1,000
// features fills ~1.5% of a table's 65,536 words (at 12 bits it filled ~22%, a score floor that drowned
// revisits in unrelated keyframes). An inverted index (word -> keyframes, counts) with
// idf weights (log(N / df), recomputed at query time) scores keyframes by idf-weighted histogram
// intersection normalised by the query's own mass, so scores lie in [0, 1].
//
// Limits: the words are not adapted to the data, so they are noisier than a trained vocabulary (DBoW2): a
// strong viewpoint or scale change drops the shared-word fraction quickly, and repetitive texture gives
// unrelated keyframes a non-zero floor. Hits are therefore only candidates; geometric verification decides.
// Words seen in more than `stop_word_fraction` of the keyframes are skipped (cost and no information).
#include <cstdint>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace rgbdmap {

struct BinaryWordsConfig {
  int tables = 3;                    ///< independent hash tables (words per descriptor)
  int bits_per_word = 16;            ///< sampled bits per table: 2^bits words per table (1..20)
  double stop_word_fraction = 0.25;  ///< words in more than this fraction of keyframes are skipped at query
  unsigned seed = 7;                 ///< bit positions; every process must use the same seed
};

/// Sparse word histogram of one keyframe: (word id, count), sorted by word id.
using WordHistogram = std::vector<std::pair<uint32_t, uint16_t>>;

/// Maps ORB descriptors (N x 32, CV_8U) to words. Stateless after construction; thread-safe.
class BinaryWordHasher {
 public:
  explicit BinaryWordHasher(const BinaryWordsConfig& config = {});
  WordHistogram histogram(const cv::Mat& descriptors) const;
  uint32_t wordCount() const { return static_cast<uint32_t>(tables_) << bits_; }

 private:
  int tables_;
  int bits_;
  std::vector<uint16_t> bit_index_;  ///< tables x bits positions in [0, 256)
};

struct RetrievalHit {
  int keyframe_id = -1;
  int robot_id = -1;
  double score = 0.0;  ///< [0, 1]
};

/// Which documents a query may return.
struct RetrievalQuery {
  int robot_id = -1;        ///< the querying keyframe's robot
  int robot_sequence = 0;   ///< its sequence number within that robot (0, 1, ... in insertion order)
  int exclude_recent = 15;  ///< same-robot keyframes with sequence > robot_sequence - this are skipped
  int top_n = 5;
  double min_score = 0.0;  ///< hits scoring below this are dropped
};

/// Inverted index over keyframes of all robots.
class BinaryWordIndex {
 public:
  explicit BinaryWordIndex(const BinaryWordsConfig& config = {});

  /// Adds a keyframe; robot_sequence as in RetrievalQuery. Keyframe ids must be unique (not checked here).
  void insert(int keyframe_id, int robot_id, int robot_sequence, const WordHistogram& words);
  /// Best top_n keyframes by score, best first. Const: changes nothing.
  std::vector<RetrievalHit> query(const WordHistogram& words, const RetrievalQuery& q) const;

  size_t size() const { return docs_.size(); }
  /// Postings stored (one per word of each inserted histogram), and the heap the index holds (capacities).
  uint64_t postings() const { return postings_count_; }
  size_t memoryBytes() const;

 private:
  struct Doc {
    int keyframe_id, robot_id, robot_sequence;
  };
  /// One word's posting list, compressed (the index was ~36 KB per keyframe as 8-byte
  /// postings): documents in insertion order, each as a varint of (gap to the previous document << 1 |
  /// count > 1), followed by a varint of the count when it is more than 1. Most postings take one byte.
  struct PostingList {
    std::vector<uint8_t> bytes;
    uint32_t last_doc = 0;
    uint32_t df = 0;  ///< documents listed
  };
  bool excluded(const Doc& d, const RetrievalQuery& q) const;
  /// idf of a word; 0 for stop words (in more than stop_word_fraction of the documents).
  double idf(uint32_t word, bool* stop) const;
  BinaryWordsConfig config_;
  std::vector<PostingList> postings_;  ///< per word id
  std::vector<Doc> docs_;
  uint64_t postings_count_ = 0;
  size_t list_bytes_ = 0;  ///< capacity of every list's bytes
};

}  // namespace rgbdmap
