#pragma once
// The robot's durable keyframe spool: every keyframe the robot makes is written here before the link offers
// it to the server, and leaves only when the server answers it (accepted or refused). A robot killed, shut
// down or cut off keeps its unanswered keyframes; its next start sends them first, as the keyframes they
// were (same session, segment and id), so the server places them in their chains.
//
// Folder (one robot, one process at a time: LOCK is flock'ed):
//   SPOOL            text, written atomically: format, robot id, session, and the keyframe ids and segments
//                    reserved so far (every id the robot used is below them, also of keyframes already
//                    answered and removed: a resumed session never reuses one)
//   kf-<id>.rec      one keyframe, written atomically (temporary name, fsync, rename, folder fsync):
//                    24-byte header (magic "RKSP", version u16, reserved u16, session i64, payload length
//                    u32, CRC-32 of the payload u32; all little-endian), CRC-32 of those 24 bytes (u32),
//                    then msg::encodePayload(Keyframe) (unsealed; every transmission seals afresh)
//   damaged/         records that failed their checks at open, moved aside (counted, never sent)
//
// Session: a spool that holds keyframes at open resumes their session (the link signs with it, its sequence
// numbers continuing above any the session used: microseconds since the session began); an empty spool
// starts a new one. Keyframe ids and segments continue above the reserved ones (VisualOdometry numbering).
//
// Budget: at most max_bytes of records. A keyframe that does not fit (budget, or the disk refusing the
// write) is not spooled: append() fails with the reason and the robot sends it live only (in memory).
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct KeyframeSpoolOptions {
  std::string directory;                   ///< this robot's spool folder (created if missing)
  uint64_t max_bytes = uint64_t{2} << 30;  ///< disk budget for records (2 GiB ~ 35,000 keyframes of 60 KB)
};

struct KeyframeSpoolStats {
  uint64_t depth = 0;         ///< keyframes spooled and not answered
  uint64_t bytes = 0;         ///< their records on disk
  uint64_t recovered = 0;     ///< of depth at open: left by an earlier process
  uint64_t appended = 0;      ///< written by this process
  uint64_t removed = 0;       ///< answered and deleted by this process
  uint64_t damaged = 0;       ///< records that failed a check at open (moved to damaged/)
  uint64_t not_spooled = 0;   ///< keyframes that did not fit (budget or disk): live only
  uint64_t write_errors = 0;  ///< of not_spooled: the file system refused (full disk, I/O error)
  int64_t oldest_utime = 0;   ///< wall clock (us) the oldest spooled keyframe was spooled (0: none)
};

class KeyframeSpool {
 public:
  /// Opens (creating) the folder for `robot_id`, takes its lock, checks every record and keeps the intact
  /// ones in id order. Fails when the folder cannot be made or locked, or belongs to another robot.
  static Result<std::unique_ptr<KeyframeSpool>> open(const KeyframeSpoolOptions& options,
                                                     const std::string& robot_id);
  ~KeyframeSpool();
  KeyframeSpool(const KeyframeSpool&) = delete;
  KeyframeSpool& operator=(const KeyframeSpool&) = delete;

  int64_t session() const { return session_; }
  bool resumed() const { return resumed_; }  ///< the session of keyframes left by an earlier process
  /// The first sequence number the link's signers use (0 for a new session).
  int64_t firstSeq() const { return first_seq_; }
  int firstKeyframeId() const { return first_keyframe_id_; }  ///< for this process's odometry
  int firstSegment() const { return first_segment_; }
  /// Keyframe ids spooled and not answered, ascending (those left by earlier processes first).
  std::vector<int> pending() const;

  /// Writes the keyframe durably (its id must be new and its segment and id at least the first ones).
  /// Fails without writing when it does not fit the budget or the disk refuses it (counted).
  Status append(const msg::Keyframe& keyframe);
  /// The spooled keyframe, read and checked again; the reason when it is gone or damaged.
  Result<msg::Keyframe> read(int keyframe_id) const;
  /// The server answered it: the record is deleted. Unknown ids are ignored.
  void remove(int keyframe_id);
  KeyframeSpoolStats stats() const;
  const std::string& directory() const { return options_.directory; }

 private:
  struct Entry {
    uint64_t bytes = 0;
    int64_t spooled_utime = 0;
  };
  KeyframeSpool(KeyframeSpoolOptions options, std::string robot_id);
  Status lockFolder();
  Status scan();  ///< reads SPOOL and every record; moves damaged ones aside
  Status writeState(int reserved_id, int reserved_segment);
  std::string recordPath(int keyframe_id) const;
  void moveAside(const std::string& name, const std::string& reason);

  const KeyframeSpoolOptions options_;
  const std::string robot_id_;
  int lock_fd_ = -1;
  int64_t session_ = 0, first_seq_ = 0;
  bool resumed_ = false;
  int first_keyframe_id_ = 0, first_segment_ = 0;
  mutable std::mutex mutex_;                    ///< everything below
  int reserved_id_ = 0, reserved_segment_ = 0;  ///< ids and segments below these are reserved in SPOOL
  std::map<int, Entry> entries_;
  KeyframeSpoolStats stats_;
};

/// The record bytes of a keyframe (tests write damaged ones with it).
Result<std::string> encodeSpoolRecord(int64_t session, msg::Keyframe keyframe);
/// The keyframe in record bytes, with every check; the reason otherwise.
Result<msg::Keyframe> decodeSpoolRecord(const std::string& bytes, int64_t* session);

}  // namespace rgbdmap
