#pragma once
// RobotLink's state and threads (private). robot_link.cpp: lifecycle, Hello/Heartbeat, keyframe sending;
// robot_link_receive.cpp: the transport handlers (acks, corrections, slices, commands, status).
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/common/sample_reservoir.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "wall_clock.hpp"

namespace rgbdmap {

class RobotLink::Impl : public std::enable_shared_from_this<RobotLink::Impl> {
 public:
  using Clock = std::chrono::steady_clock;

  Impl(transport::Transport& transport, RobotLinkOptions options);
  ~Impl();

  Status start();
  void stop();
  Status sendKeyframe(const Keyframe& keyframe, const RgbdFrame& frame);
  Status sendKeyframeMessage(msg::Keyframe message);
  void setTrackingState(int last_keyframe_id, int segment, TrackingState state);
  Status publishCommand(msg::VelocityCommand command);
  Status publishPose(double timestamp, int segment, int reference_keyframe, TrackingState state,
                     const SE3& T_odom_cam);
  SE3 mapFromOdom(int segment) const;
  std::optional<SE3> correctedKeyframe(int keyframe_id) const;
  template <typename T>
  std::optional<T> latest(const std::optional<T> Impl::*member) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return this->*member;
  }
  bool waitAllAcked(double timeout_s);
  bool waitForCorrection(int keyframe_id, double timeout_s);
  bool waitForGraphRevision(int64_t revision, double timeout_s);
  RobotLinkStats stats() const;
  std::map<int, int64_t> keyframeAckTimes() const;

  std::optional<msg::OccupancySlice> slice_;
  std::optional<msg::VelocityCommand> command_;
  std::optional<msg::ServerStatus> status_;
  std::optional<bool> placed_;  ///< a localising robot: placed in the stored map, as the last status says

 private:
  enum class Answer { kPending, kAccepted, kRefused };
  struct ChunkTransfer {  ///< the sealed keyframe envelope being sent in chunks
    std::shared_ptr<const msg::Bytes> envelope;
    int64_t transfer_id = -1;
    std::vector<bool> received;     ///< per chunk, from the server's ChunkAcks
    Clock::time_point completed{};  ///< a ChunkAck said every chunk arrived (the epoch before)
    int ack_rounds = 0;  ///< resends answering a ChunkAck (bounded; then only the deadlines resend)
    /// Per chunk, the number of its latest send in this transfer (1, 2, ...; 0 never sent): a ChunkAck
    /// that shows a chunk sent later as received proves the missing ones sent before it lost.
    std::vector<uint32_t> sent_seq;
    uint32_t sends = 0;              ///< chunk sends of this transfer so far (the latest sent_seq)
    uint32_t burst_first = 0;        ///< sent_seq of the latest burst's first chunk
    Clock::time_point burst_sent{};  ///< the latest burst started
    bool burst_answered = true;      ///< a ChunkAck answered it (its round trip: ReliableSender::progress)
  };
  struct SentKeyframe {
    int segment = 0;
    SE3 T_odom_cam = SE3::Identity();
    std::unique_ptr<msg::Keyframe> message;  ///< encoded, unsealed; dropped once answered or last sent
    int transmissions = 0;
    int reseals = 0;  ///< chunked: transfers sealed anew after the first
    Answer answer = Answer::kPending;
    Clock::time_point first_sent{};  ///< submitted (its first transmission follows at once)
    int64_t accepted_utime = 0;      ///< wall clock (us) of its accepting ack; 0 before
    ChunkTransfer transfer;          ///< chunk_bytes > 0 only
    bool spooled = false;    ///< in the keyframe spool: requeued when given up, removed from it when answered
    bool recovered = false;  ///< left in the spool by an earlier process
    bool fed = false;        ///< submitted to the ReliableSender at least once
  };
  /// What one keyframe adds to the byte counters (RobotLinkStats::keyframe_*_bytes).
  struct KeyframeBytes {
    size_t depth = 0, color = 0, features = 0, message = 0;
  };

  // Sending (robot_link.cpp).
  Status transmitKeyframe(uint64_t id);  ///< ReliableSender's callback: seals afresh, publishes
  template <typename T>
  Status sealAndPublish(const T& message, const std::string& channel);
  void runPeriodic();  ///< Hello until the server answered, Heartbeat, and a tick for waiters
  /// From kDiagnoseAfterS after the start: what is likely wrong and which setting to look at (a server that
  /// says it does not serve this robot, keys that differ, or no server for this robot on this transport),
  /// logged when it changes (also when a server is heard after all) and kept in counts_.diagnosis. Nothing
  /// else changes: keyframes are kept and retried.
  void diagnoseLink(Clock::time_point now);  ///< caller holds mutex_
  Status sendHello();
  Status sendHeartbeat();
  msg::LinkStatus linkStatus() const;  ///< from stats() and the send window (robot_link_pose.cpp)
  Status sendLinkStatus();
  bool allAnswered() const;                             ///< caller holds mutex_
  void countKeyframeBytes(const KeyframeBytes& bytes);  ///< once per keyframe; caller holds mutex_

  // The keyframe spool (robot_link_spool.cpp); everything here needs options_.spool.
  void startSpool();  ///< queues what an earlier process left, starts the feeder
  /// A keyframe written to the spool: queued for the send window (the feeder submits it).
  Status enqueueSpooled(msg::Keyframe message, const KeyframeBytes& bytes);
  void noteSpooled(const Status& spooled);  ///< counts a keyframe the spool refused; logs live-only changes
  void runFeeder();                         ///< moves queued keyframes into the send window while it has room
  /// The send window now: max_pending, or kOutageWindow while unanswered keyframes get no answer at all.
  size_t windowLimit(Clock::time_point now) const;  ///< caller holds mutex_
  void onGivenUp(uint64_t id);         ///< the ReliableSender gave a keyframe up: a spooled one is requeued
  void noteAnswered(int keyframe_id);  ///< a spooled keyframe was answered: its record goes (no lock held)
  void addSpoolStats(RobotLinkStats* s) const;  ///< caller holds mutex_

  // Chunked keyframes (robot_link_chunks.cpp).
  bool chunking() const { return options_.chunk_bytes > 0; }
  /// The channel keyframes travel on: chunks, or whole keyframes.
  const std::string& deliveryChannel() const { return chunking() ? chunk_channel_ : keyframe_channel_; }
  /// False while the transport matches endpoints and no subscriber of deliveryChannel() is matched
  /// (robot_link_match.cpp): a keyframe published now would reach nobody.
  bool deliveryMatched();
  /// Periodic thread, mutex_ not held: a subscriber newly matched while keyframes are in flight gets them
  /// at once. True while matching applies (the periodic thread then wakes every kMatchPoll).
  bool watchMatches();
  /// options.reliable, with shared_backoff off when chunking (each keyframe's bursts are answered and
  /// timed on their own).
  /// The ReliableSender's options: link.reliable, with per-keyframe backoff for chunks and, on a transport
  /// that repairs losses itself (DDS), no resend within kRepairedFirstResend.
  static transport::ReliableSenderOptions senderOptions(const RobotLinkOptions& options, bool repairs_loss);
  /// How long a transfer whose every chunk arrived waits for its KeyframeAck before it is sealed anew, after
  /// `reseals` such transfers of the same keyframe.
  Clock::duration resealAfter(int reseals) const;  ///< caller holds mutex_
  Status transmitChunked(int keyframe_id);  ///< the missing chunks, or a new transfer when none are missing
  /// Sends `indices` in that order as one burst, its last kFlaggedChunks flagged last-of-burst; a burst
  /// that is `probe` gets no progress() from its ChunkAck.
  Status sendChunks(int keyframe_id, const std::shared_ptr<const msg::Bytes>& envelope, int64_t transfer_id,
                    const std::vector<int>& indices, bool probe = false);
  void handle(const msg::ChunkAck& ack);

  // Receiving (robot_link_receive.cpp).
  Status subscribeAll();
  template <typename T>
  Status subscribe();
  template <typename T>
  void onMessage(const uint8_t* data, size_t size);
  bool isForMe(const std::string& robot_id);
  void handle(const msg::KeyframeAck& ack);
  void handle(const msg::PoseCorrections& corrections);
  void handle(const msg::OccupancySlice& slice);
  void handle(const msg::VelocityCommand& command);
  void handle(const msg::ServerStatus& status);
  /// A ServerStatus from "server" read without verifying it (a hint only), or nothing.
  std::optional<msg::ServerStatus> unverifiedStatus(const uint8_t* data, size_t size) const;
  void readUnverifiedStatus(const uint8_t* data, size_t size);  ///< one that failed its signature check
  /// The unsigned answer of a server that does not serve this robot (server intake's RefusalNotices):
  /// counted and read as a hint; false for anything else.
  bool readNotServedNotice(const uint8_t* data, size_t size);
  void noteServerRejects(const msg::ServerStatus& status, bool verified);  ///< caller holds mutex_
  void updateSegmentAnchors(const msg::PoseCorrections& corrections);      ///< caller holds mutex_

  transport::Transport& transport_;
  const RobotLinkOptions options_;
  KeyframeSpool* const spool_;  ///< options_.spool.get()
  std::string hello_channel_, heartbeat_channel_, keyframe_channel_;
  msg::KeyStore keys_;
  msg::ReplayGuard replay_guard_;
  /// Rejected messages; logged at most every 30 s (diagnoseLink() names the likely cause from 3 s on).
  msg::RejectCounters rejects_{1.0 / 30.0};
  const msg::KeyStore unverified_keys_ = msg::KeyStore::openMode(false);  ///< readUnverifiedStatus only
  std::mutex signer_mutex_;
  /// One session for both signers: the server sends PoseCorrections only for keyframes of the session the
  /// robot's Hello announced.
  const int64_t session_;  ///< the spool's (maybe resumed) session, else a new one
  msg::Signer signer_;
  /// Keyframe envelopes sent in chunks: their own seq stream, so the server's replay window (64 per message
  /// type) is not pushed past a keyframe by the hundred chunk envelopes of the next ones.
  std::mutex keyframe_signer_mutex_;
  msg::Signer keyframe_signer_;
  std::string chunk_channel_;
  transport::ReliableSender reliable_;
  const Clock::time_point created_ = Clock::now();

  mutable std::mutex mutex_;  ///< everything below; taken before the ReliableSender's own lock, never after
  std::condition_variable changed_;  ///< answers, corrections, stop, and the periodic tick
  bool started_ = false, stopping_ = false, heard_from_server_ = false;
  /// The server registered this robot (a message addressed to it, or its status lists it). Until then the
  /// Hello is resent every hello_period_s: under loss the server may be heard before it heard the Hello,
  /// and keyframes wait unacknowledged for the robot's Hello.
  bool server_knows_me_ = false;
  std::map<int, SentKeyframe> sent_;
  std::set<int> queue_;   ///< spooled keyframes waiting for room in the send window, in id (chain) order
  bool feeding_ = false;  ///< the feeder holds a keyframe taken from queue_ and not yet submitted
  Clock::time_point last_answer_ = Clock::now();  ///< the latest KeyframeAck or ChunkAck
  bool live_only_ = false;  ///< the spool's last append failed (logged when this changes)
  std::thread feeder_;
  std::map<int, SE3> T_map_cam_;   ///< corrected keyframes
  std::map<int, SE3> T_map_odom_;  ///< per segment
  int64_t graph_revision_ = -1, corrections_session_ = 0;
  int last_keyframe_id_ = -1, segment_ = 0;
  TrackingState tracking_state_ = TrackingState::kInitialized;
  SampleReservoir ack_latency_ms_{1024};
  /// Smoothed time from "every chunk arrived" to the KeyframeAck (the server storing it): a transfer is
  /// sealed anew only when its ack is this late several times over (robot_link_chunks.cpp).
  double store_ack_ms_ = 0.0;
  RobotLinkStats counts_;  ///< the counters kept here (the rest come from the sender and rejects_)
  std::atomic<uint64_t> bytes_sent_{0}, bytes_received_{0};
  /// Hashes of the last commands this link published: their echo on the subscribed cmd_vel channel is
  /// dropped before the envelope check (it is this robot's message, not a forged server one).
  std::deque<size_t> own_commands_;
  std::mutex lifecycle_;  ///< serialises start() and stop()
  std::thread periodic_;
  std::mutex pose_mutex_;  ///< publishPose's throttle
  std::optional<Clock::time_point> last_pose_;
  std::string pose_channel_, link_status_channel_;
  std::atomic<uint64_t> matched_total_{0};  ///< the delivery channel's subscribers ever matched, last seen
};

}  // namespace rgbdmap
