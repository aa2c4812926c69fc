#pragma once
// Durable keyframe store of the mapping server: every received keyframe (with its images) and every
// verified loop-closure edge, in append-only log files of a map directory, so that a server killed at any
// point (kill -9, power loss after fdatasync) restarts on the same directory without losing an acknowledged
// keyframe and resumes the same graph. Format, guarantees and limits: server/store/README.md.
//
// Threads: one MapStore per directory (an flock on <dir>/LOCK keeps other processes and other MapStore
// objects out). appendKeyframe/appendLoop may be called from any thread (they serialise); readKeyframe,
// recovery, bytesOnDisk and directory may run concurrently with them. keyframes() and loops() return the
// in-memory lists that appends grow: read them from the appending thread, or not while appending.
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

/// Written into <dir>/MANIFEST; a store with another version is refused (no silent migration).
constexpr int kMapStoreFormatVersion = 1;

struct StoredKeyframe {
  int64_t node_id = 0;     ///< the server's global keyframe id (unique in the map), >= 0
  int64_t session = 0;     ///< sender session (Header::session) of the robot process that sent it
  msg::Keyframe keyframe;  ///< as received (robot_id, segment_id, keyframe_id, poses, features, images)
};

struct StoredLoop {
  int64_t from_node = 0, to_node = 0;  ///< node ids of stored keyframes, different from each other
  SE3 T_from_to = SE3::Identity();
  Mat6 information = Mat6::Identity();  ///< finite and symmetric
  int inliers = 0;                      ///< >= 0
  double motion_measure = 0.0;          ///< finite
  /// The verified feature matches (index in from, index in to), each >= 0, at most kMaxStoredLoopPairs:
  /// a restarted server rebuilds the bundle adjustment's landmark tracks from them. Empty in records
  /// written before they were stored.
  std::vector<std::pair<int, int>> inlier_pairs;
};
constexpr size_t kMaxStoredLoopPairs = 100000;

struct MapStoreOptions {
  bool sync = true;  ///< fdatasync after every append (durability); false only for benchmarks/tests
  /// recover() writes this many bytes past the end of the keyframe log (and cuts them off again) to check
  /// that appends fit again: about two 640x480 keyframe records.
  int64_t recover_probe_bytes = 256 * 1024;
};

/// Whether appends work now, and how often they stopped and came back since open().
struct MapStoreHealth {
  bool failed = false;
  std::string error;              ///< why appends stopped (or why the last recovery failed); "" when ok
  uint64_t failures = 0;          ///< appends that hit an I/O error and stopped appends
  uint64_t recover_attempts = 0;  ///< recover() calls on a failed store
  uint64_t recoveries = 0;        ///< of which took the store back into service
};

/// What open() found.
struct MapStoreRecovery {
  int keyframes = 0, loops = 0;
  int corrupt_records = 0;            ///< bad CRC / undecodable, skipped (counted and logged)
  int64_t truncated_bytes = 0;        ///< an incomplete tail record (crash mid-write) cut off
  std::vector<std::string> problems;  ///< human-readable, one per problem
};

class MapStore {
 public:
  /// Creates the directory if missing; otherwise reads and verifies what is there. Never fails because of
  /// a corrupt or truncated record (those are skipped, counted and the file is repaired by truncating an
  /// incomplete tail); fails only if the directory cannot be created/opened/locked, or the store was
  /// written by an incompatible format version (clear message). Holds an exclusive lock (flock on a LOCK
  /// file) so two servers cannot write one map directory.
  static Result<std::unique_ptr<MapStore>> open(const std::string& dir, MapStoreOptions options = {});
  ~MapStore();
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;

  /// Durable on return (when options.sync). Fails (nothing written) on a duplicate node_id, a negative
  /// node_id or a keyframe that msg::validate rejects. After an I/O error every later append fails until
  /// recover() succeeds.
  Status appendKeyframe(const StoredKeyframe& keyframe);
  /// appendKeyframe of a record payload as readKeyframePayload gives it (another store's): decoded and
  /// checked the same way, and stored byte for byte (map bundles copy a map exactly).
  Status appendKeyframePayload(const msg::Bytes& payload);
  /// Durable on return (when options.sync). Both nodes must be stored keyframes.
  Status appendLoop(const StoredLoop& loop);
  /// Several loops in one write and one fdatasync (each is validated first; after a crash a prefix may
  /// remain).
  Status appendLoops(const std::vector<StoredLoop>& loops);

  /// Keyframes in append order WITHOUT images and features (images.depth, images.color, keypoints and
  /// descriptors empty; width, height and colour codec kept) - the server keeps these in memory; images
  /// and features are read back on demand (readKeyframe).
  const std::vector<StoredKeyframe>& keyframes() const;
  /// Loops in append order WITHOUT their inlier pairs (empty): those are read back on demand
  /// (readLoopPairs), so the list costs ~0.4 KB per loop instead of a few KB with its pairs.
  const std::vector<StoredLoop>& loops() const;
  /// The inlier pairs of loops()[i], read back from disk; fails for an index out of range or a record
  /// that no longer verifies. Thread-safe with respect to concurrent appends.
  Result<std::vector<std::pair<int, int>>> readLoopPairs(size_t i) const;
  /// Reads one keyframe (with images) back from disk; fails for an unknown id or a record that no longer
  /// verifies. Thread-safe with respect to concurrent appends.
  Result<StoredKeyframe> readKeyframe(int64_t node_id) const;
  /// The keyframe's record payload as stored (CRC, decoding and node id verified), for appendKeyframePayload.
  Result<msg::Bytes> readKeyframePayload(int64_t node_id) const;

  /// Takes a failed store back into service (success at once when it is not failed): both logs are cut
  /// back to their last acknowledged record and synced, then a probe write past the end of the keyframe
  /// log (options.recover_probe_bytes, cut off again) checks that appends fit. While the cause lasts (a
  /// full disk) it fails and the store stays failed: call it again later. Nothing stored before is lost,
  /// only the bytes of the append that failed (never acknowledged). Thread-safe.
  Status recover();
  /// A copy of the current health; thread-safe and never waits for an append's fdatasync.
  MapStoreHealth health() const;

  const MapStoreRecovery& recovery() const;
  /// Bytes of the two log files (what the records occupy).
  int64_t bytesOnDisk() const;
  const std::string& directory() const;

 private:
  struct State;
  explicit MapStore(std::unique_ptr<State> state);
  Status appendEncodedKeyframe(const StoredKeyframe& keyframe, const msg::Bytes& payload);
  /// The record of node_id, verified, with its decoded keyframe.
  Result<std::pair<msg::Bytes, StoredKeyframe>> readVerifiedKeyframe(int64_t node_id,
                                                                     bool keep_payload) const;
  std::unique_ptr<State> state_;
};

}  // namespace rgbdmap
