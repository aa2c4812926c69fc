// RobotLink: lifecycle, Hello/Heartbeat worker, keyframe sending through the ReliableSender.
#include "rgbdmap/link/robot_link.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <functional>
#include <string_view>
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/link/link_config_tables.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

#include "robot_link_impl.hpp"

namespace rgbdmap {
namespace {

/// The Hello's period (at most) once the server was heard but has not shown it registered this robot: the
/// server holds the robot's keyframes, unanswered, until a Hello arrives (on a lossy link one may not).
constexpr std::chrono::milliseconds kHelloPeriodWhenHeard{200};
/// DDS: how soon a newly matched subscriber (a restarted server) gets the keyframes in flight.
constexpr std::chrono::milliseconds kMatchPoll{50};

std::chrono::nanoseconds seconds(double s) {
  return std::chrono::nanoseconds(static_cast<int64_t>(std::clamp(s, 0.0, 1e9) * 1e9));
}

msg::KeyStore makeKeyStore(const RobotLinkOptions& options) {
  if (options.key.empty()) return msg::KeyStore::openMode();
  msg::KeyStore keys;
  (void)keys.add(msg::kServerId, options.key);  // validate() reports a bad key before start() uses it
  return keys;
}

}  // namespace

std::string RobotLinkOptions::validate() const {
  std::string out;
  auto fail = [&out](const std::string& reason) { out += (out.empty() ? "" : "; ") + reason; };
  if (!msg::channelFor(msg::MessageType::kHello, robot_id)) fail("invalid robot id '" + robot_id + "'");
  if (robot_id == msg::kServerId) fail("robot id must not be 'server'");
  if (!key.empty() && key.size() < msg::kMinKeyBytes)
    fail("key must be empty (unsigned) or at least " + std::to_string(msg::kMinKeyBytes) + " bytes");
  if (const std::string e = camera.validate(); !e.empty()) fail("camera: " + e);
  if (!se3::isValid(T_base_camera, 1e-6) || !(T_base_camera.translation().norm() <= kMaxCameraOffsetM))
    fail("T_base_camera must be a rigid transform within " + std::to_string(kMaxCameraOffsetM) + " m");
  if (chunk_bytes > 0 && chunk_bytes < msg::kMinChunkBytes)
    fail("chunk_bytes must be -1, 0 or " + std::to_string(msg::kMinChunkBytes) + ".." +
         std::to_string(msg::kMaxChunkBytes));
  if (!send_features && codec.color == ColorCodec::kNone)
    fail("send_features false needs colour (codec.color not none): the server extracts features from it");
  for (const std::string& problem : robotLinkConfigTable().problems(*this)) fail(problem);
  return out;
}

RobotLink::Impl::Impl(transport::Transport& transport, RobotLinkOptions options)
    : transport_(transport),
      options_(std::move(options)),
      spool_(options_.spool.get()),
      keys_(makeKeyStore(options_)),
      session_(spool_ ? spool_->session() : msg::newSessionId()),
      signer_(options_.robot_id, options_.key, session_, spool_ ? spool_->firstSeq() : 0),
      keyframe_signer_(options_.robot_id, options_.key, session_, spool_ ? spool_->firstSeq() : 0),
      reliable_(
          senderOptions(options_, transport.repairsLoss()),
          [this](uint64_t id) { return transmitKeyframe(id); }, [this](uint64_t id) { onGivenUp(id); }) {}

RobotLink::Impl::~Impl() { stop(); }

Status RobotLink::Impl::start() {
  std::lock_guard<std::mutex> life(lifecycle_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (started_) return Status::failure("RobotLink::start: already started");
    if (stopping_) return Status::failure("RobotLink::start: stopped before it started");
    started_ = true;
  }
  if (const std::string e = options_.validate(); !e.empty()) return Status::failure("RobotLink: " + e);
  hello_channel_ = *msg::channelFor(msg::MessageType::kHello, options_.robot_id);
  heartbeat_channel_ = *msg::channelFor(msg::MessageType::kHeartbeat, options_.robot_id);
  keyframe_channel_ = *msg::channelFor(msg::MessageType::kKeyframe, options_.robot_id);
  chunk_channel_ = *msg::channelFor(msg::MessageType::kKeyframeChunk, options_.robot_id);
  pose_channel_ = *msg::channelFor(msg::MessageType::kRobotPose, options_.robot_id);
  link_status_channel_ = *msg::channelFor(msg::MessageType::kLinkStatus, options_.robot_id);
  if (Status s = subscribeAll(); !s) return s;
  if (Status s = transport_.start(); !s) return Status::failure("RobotLink: transport: " + s.error());
  reliable_.start();
  // Subscribers matched before anything was sent are no news to the keyframes in flight (none yet).
  if (const auto match = transport_.matchedSubscribers(deliveryChannel())) matched_total_ = match->total;
  if (Status s = sendHello(); !s) log::warn("robot ", options_.robot_id, ": first Hello failed: ", s.error());
  periodic_ = std::thread([this] { runPeriodic(); });
  if (spool_) startSpool();
  log::info("robot ", options_.robot_id, ": link started (", options_.key.empty() ? "unsigned" : "signed",
            ", heartbeat ", options_.heartbeat_period_s, " s, send window ", options_.reliable.max_pending,
            chunking() ? ", keyframes in chunks of " + std::to_string(options_.chunk_bytes) + " bytes" : "",
            ")");
  return Status::success();
}

void RobotLink::Impl::stop() {
  std::lock_guard<std::mutex> life(lifecycle_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (periodic_.joinable()) periodic_.join();
  if (feeder_.joinable()) feeder_.join();
  reliable_.stop();
}

template <typename T>
Status RobotLink::Impl::sealAndPublish(const T& message, const std::string& channel) {
  Result<msg::Bytes> bytes = [&] {
    std::lock_guard<std::mutex> lock(signer_mutex_);
    return signer_.seal(message, nowUtime());
  }();
  if (!bytes) return Status::failure(std::string("seal ") + msg::toString(T::kType) + ": " + bytes.error());
  Status s = transport_.publish(channel, *bytes);
  if (s) bytes_sent_ += bytes->size();
  return s;
}

// robot_link_chunks.cpp seals chunks with it.
template Status RobotLink::Impl::sealAndPublish(const msg::KeyframeChunk&, const std::string&);
// robot_link_pose.cpp publishes the live pose with it.
template Status RobotLink::Impl::sealAndPublish(const msg::RobotPose&, const std::string&);
template Status RobotLink::Impl::sealAndPublish(const msg::LinkStatus&, const std::string&);

Status RobotLink::Impl::publishCommand(msg::VelocityCommand command) {
  command.robot_id = options_.robot_id;
  Result<msg::Bytes> bytes = [&] {
    std::lock_guard<std::mutex> lock(signer_mutex_);
    return signer_.seal(command, nowUtime());
  }();
  if (!bytes) return Status::failure(std::string("seal VelocityCommand: ") + bytes.error());
  const Result<std::string> channel = msg::channelFor(msg::MessageType::kVelocityCommand, options_.robot_id);
  if (!channel) return Status::failure(channel.error());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    own_commands_.push_back(std::hash<std::string_view>()(
        std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size())));
    if (own_commands_.size() > 16) own_commands_.pop_front();
  }
  Status s = transport_.publish(*channel, *bytes);
  if (!s) return s;
  bytes_sent_ += bytes->size();
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_.commands_sent;
  return s;
}

msg::Hello makeHello(const RobotLinkOptions& options) {
  msg::Hello hello;
  hello.robot_id = options.robot_id;
  hello.header.sender = options.robot_id;  // seal() stamps the rest of the header
  hello.camera = options.camera;
  hello.T_base_camera = options.T_base_camera;
  hello.software_version = options.software_version;
  hello.capabilities = {"keyframes", "pose_corrections", "occupancy_slice", "velocity_command"};
  if (options.localize) hello.capabilities.push_back(msg::kCapabilityLocalize);
  return hello;
}

Status RobotLink::Impl::sendHello() {
  const msg::Hello hello = makeHello(options_);
  Status s = sealAndPublish(hello, hello_channel_);
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.hellos_sent += s.ok() ? 1 : 0;
  return s;
}

Status RobotLink::Impl::sendHeartbeat() {
  msg::Heartbeat hb;
  hb.robot_id = options_.robot_id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    hb.last_keyframe_id = last_keyframe_id_;
    hb.segment_id = segment_;
    hb.tracking_state = static_cast<int>(tracking_state_);
  }
  hb.uptime_s = std::chrono::duration<double>(Clock::now() - created_).count();
  Status s = sealAndPublish(hb, heartbeat_channel_);
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.heartbeats_sent += s.ok() ? 1 : 0;
  return s;
}

void RobotLink::Impl::runPeriodic() {
  const auto hb_period = std::chrono::duration_cast<Clock::duration>(seconds(options_.heartbeat_period_s));
  const auto hello_period = std::chrono::duration_cast<Clock::duration>(seconds(options_.hello_period_s));
  const auto heard_period = std::min<Clock::duration>(hello_period, kHelloPeriodWhenHeard);
  Clock::time_point next_heartbeat = Clock::now(), last_hello = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    const auto now = Clock::now();
    const auto next_hello = last_hello + (heard_from_server_ ? heard_period : hello_period);
    const bool heartbeat_due = now >= next_heartbeat, hello_due = !server_knows_me_ && now >= next_hello;
    lock.unlock();
    if (heartbeat_due) {
      if (Status s = sendHeartbeat(); !s) log::debug("robot ", options_.robot_id, ": heartbeat: ", s.error());
      if (Status s = sendLinkStatus(); !s)
        log::debug("robot ", options_.robot_id, ": link status: ", s.error());
      next_heartbeat = std::max(next_heartbeat + hb_period, now);
    }
    if (hello_due) {
      if (Status s = sendHello(); !s) log::debug("robot ", options_.robot_id, ": hello: ", s.error());
      last_hello = now;
    }
    const bool matching = watchMatches();
    lock.lock();
    diagnoseLink(Clock::now());
    changed_.notify_all();  // waiters re-check: a keyframe may have been given up meanwhile
    // Unregistered: awake at least every heard_period, so a server heard meanwhile gets its Hello soon.
    auto wake = server_knows_me_ ? next_heartbeat : std::min(next_heartbeat, last_hello + heard_period);
    if (matching) wake = std::min(wake, Clock::now() + kMatchPoll);
    changed_.wait_until(lock, wake, [this] { return stopping_; });
  }
}

Status RobotLink::Impl::sendKeyframe(const Keyframe& keyframe, const RgbdFrame& frame) {
  const std::string what = "keyframe " + std::to_string(keyframe.id);
  if (keyframe.id < 0) return Status::failure(what + ": negative id");
  Result<EncodedImages> images = encodeImages(frame, options_.codec);
  if (!images) return Status::failure(what + ": images: " + images.error());
  Result<msg::Keyframe> message =
      keyframeToMessage(keyframe, options_.robot_id, std::move(*images), options_.send_features);
  if (!message) return Status::failure(what + ": " + message.error());
  return sendKeyframeMessage(std::move(*message));
}

Status RobotLink::Impl::sendKeyframeMessage(msg::Keyframe message) {
  const int id = message.keyframe_id;
  const std::string what = "keyframe " + std::to_string(id);
  if (id < 0) return Status::failure(what + ": negative id");
  constexpr size_t kLcmKeypointBytes = 21;  // keypoint_t: 5 floats and an int8
  KeyframeBytes bytes{message.images.depth.size(), message.images.color.size(),
                      message.keypoints.size() * kLcmKeypointBytes + message.descriptors.size(), 0};
  message.robot_id = options_.robot_id;
  message.header.sender = options_.robot_id;  // seal() stamps the rest of the header
  const Result<msg::Bytes> encoded = msg::encodePayload(message);
  if (!encoded) return Status::failure(what + ": " + encoded.error());
  bytes.message = encoded->size();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!started_ || stopping_) return Status::failure(what + ": link not running");
    if (sent_.count(id)) return Status::failure(what + ": already sent");
  }
  if (spool_) {
    const Status spooled = spool_->append(message);
    noteSpooled(spooled);
    if (spooled) {
      if (options_.keyframe_tap) options_.keyframe_tap(*encoded);
      return enqueueSpooled(std::move(message), bytes);
    }
  }
  std::unique_lock<std::mutex> lock(mutex_);
  const bool room = changed_.wait_for(lock, seconds(options_.send_timeout_s), [this] {
    return stopping_ || reliable_.pending() < options_.reliable.max_pending;
  });
  if (stopping_) return Status::failure(what + ": link stopped");
  if (!room)
    return Status::failure(what + ": send window still full after " +
                           std::to_string(options_.send_timeout_s) + " s");
  SentKeyframe& entry = sent_[id];
  entry.segment = message.segment_id;
  entry.T_odom_cam = message.T_odom_cam;
  entry.message = std::make_unique<msg::Keyframe>(std::move(message));
  entry.first_sent = Clock::now();
  entry.fed = true;
  lock.unlock();  // submit() transmits on this thread (transmitKeyframe takes mutex_)
  if (Status s = reliable_.submit(static_cast<uint64_t>(id)); !s) {
    lock.lock();
    sent_.erase(id);
    return Status::failure(what + ": " + s.error());
  }
  if (options_.keyframe_tap) options_.keyframe_tap(*encoded);
  lock.lock();
  ++counts_.keyframes_sent;
  countKeyframeBytes(bytes);
  return Status::success();
}

void RobotLink::Impl::countKeyframeBytes(const KeyframeBytes& bytes) {
  counts_.keyframe_depth_bytes += bytes.depth;
  counts_.keyframe_color_bytes += bytes.color;
  counts_.keyframe_feature_bytes += bytes.features;
  counts_.keyframe_message_bytes += bytes.message;
}

Status RobotLink::Impl::transmitKeyframe(uint64_t id) {
  if (!deliveryMatched()) return Status::failure("no subscriber of " + deliveryChannel() + " matched yet");
  if (chunking()) return transmitChunked(static_cast<int>(id));
  std::unique_ptr<msg::Keyframe> last;  // the final transmission takes the message over
  msg::Keyframe copy;
  const msg::Keyframe* message = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sent_.find(static_cast<int>(id));
    if (it == sent_.end() || !it->second.message) return Status::success();  // answered meanwhile
    SentKeyframe& entry = it->second;
    const int max_attempts = options_.reliable.max_attempts;
    if (++entry.transmissions >= max_attempts && max_attempts > 0) {
      last = std::move(entry.message);  // the sender gives the id up after this one: free the images
      message = last.get();
    } else {
      copy = *entry.message;
      message = &copy;
    }
  }
  return sealAndPublish(*message, keyframe_channel_);
}

bool RobotLink::Impl::allAnswered() const {
  return std::all_of(sent_.begin(), sent_.end(),
                     [](const auto& kv) { return kv.second.answer != Answer::kPending; });
}

bool RobotLink::Impl::waitAllAcked(double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, seconds(timeout_s), [this] {
    return stopping_ || allAnswered() || (reliable_.pending() == 0 && queue_.empty() && !feeding_);
  });
  return allAnswered();
}

bool RobotLink::Impl::waitForCorrection(int keyframe_id, double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, seconds(timeout_s), [&] {
    return stopping_ || T_map_cam_.count(keyframe_id) > 0;
  }) && T_map_cam_.count(keyframe_id) > 0;
}

bool RobotLink::Impl::waitForGraphRevision(int64_t revision, double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, seconds(timeout_s), [&] {
    return stopping_ || graph_revision_ >= revision;
  }) && graph_revision_ >= revision;
}

void RobotLink::Impl::setTrackingState(int last_keyframe_id, int segment, TrackingState state) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_keyframe_id_ = last_keyframe_id;
  segment_ = segment;
  tracking_state_ = state;
}

SE3 RobotLink::Impl::mapFromOdom(int segment) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = T_map_odom_.find(segment);
  return it == T_map_odom_.end() ? options_.T_base_camera : it->second;
}

std::optional<SE3> RobotLink::Impl::correctedKeyframe(int keyframe_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = T_map_cam_.find(keyframe_id);
  if (it == T_map_cam_.end()) return std::nullopt;
  return it->second;
}

std::map<int, int64_t> RobotLink::Impl::keyframeAckTimes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<int, int64_t> out;
  for (const auto& [id, entry] : sent_)
    if (entry.accepted_utime > 0) out[id] = entry.accepted_utime;
  return out;
}

RobotLinkStats RobotLink::Impl::stats() const {
  const transport::ReliableSenderStats r = reliable_.stats();
  std::lock_guard<std::mutex> lock(mutex_);
  RobotLinkStats s = counts_;
  s.retransmissions = r.retransmissions;
  s.rtt_samples = r.rtt_samples;
  s.srtt_ms = r.srtt_ms;
  s.rttvar_ms = r.rttvar_ms;
  s.rto_ms = r.rto_ms;
  s.keyframes_given_up = r.given_up - std::min(r.given_up, counts_.keyframes_requeued);
  for (const auto& [id, entry] : sent_)
    if (entry.answer == Answer::kPending) ++(entry.spooled ? s.keyframes_pending : s.keyframes_pending_live);
  s.keyframes_pending += s.keyframes_pending_live;
  s.messages_rejected += rejects_.total();
  s.bytes_sent = bytes_sent_.load();
  s.bytes_received = bytes_received_.load();
  s.graph_revision = graph_revision_;
  s.server_heard = heard_from_server_;
  s.bad_signatures = rejects_.get(msg::RejectReason::kBadSignature);
  s.ack_latency_samples = ack_latency_ms_.count();
  s.ack_latency_ms_median = ack_latency_ms_.median();
  s.ack_latency_ms_p90 = ack_latency_ms_.quantile(0.9);
  s.ack_latency_ms_max = ack_latency_ms_.max();
  if (spool_) addSpoolStats(&s);
  return s;
}

}  // namespace rgbdmap
