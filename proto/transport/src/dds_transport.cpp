// Cyclone DDS adapter; see dds_transport.hpp.
#include "dds_transport.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "envelope.h"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::transport {
namespace {

log::RateLimiter g_dds_log(1.0);
constexpr dds_attach_t kGuardAttach = 0;

std::string ddsError(const char* what, dds_return_t rc) {
  return std::string(what) + ": " + dds_strretcode(rc);
}

}  // namespace

Result<std::unique_ptr<Transport>> DdsTransport::create(const TransportOptions& options, int domain_id) {
  using R = Result<std::unique_ptr<Transport>>;
  const dds_entity_t participant =
      dds_create_participant(static_cast<dds_domainid_t>(domain_id), nullptr, nullptr);
  if (participant < 0) return R::failure(ddsError("dds_create_participant", participant));
  const dds_entity_t waitset = dds_create_waitset(participant);
  const dds_entity_t guard = dds_create_guardcondition(participant);
  if (waitset < 0 || guard < 0 || dds_waitset_attach(waitset, guard, kGuardAttach) < 0) {
    dds_delete(participant);
    return R::failure("could not create the DDS waitset");
  }
  return R(std::unique_ptr<Transport>(new DdsTransport(options, participant, waitset, guard)));
}

DdsTransport::~DdsTransport() {
  stop();
  dds_delete(participant_);  // deletes topics, readers, writers, waitset and guard with it
}

dds_qos_t* DdsTransport::qosFor(const std::string& channel, bool writer) const {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  if (isLatestForLateJoiners(channel, options_)) {
    dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, writer ? 1 : options_.dds_history_depth);
  } else {
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, options_.dds_history_depth);
  }
  return qos;
}

Result<dds_entity_t> DdsTransport::topicFor(const std::string& channel) {
  auto it = topics_.find(channel);
  if (it != topics_.end()) return it->second;
  const dds_entity_t topic =
      dds_create_topic(participant_, &rgbdmap_Envelope_desc, ddsTopicName(channel).c_str(), nullptr, nullptr);
  if (topic < 0) return Result<dds_entity_t>::failure(ddsError("dds_create_topic", topic));
  topics_.emplace(channel, topic);
  return topic;
}

Result<dds_entity_t> DdsTransport::writerFor(const std::string& channel) {
  std::lock_guard<std::mutex> lock(entities_mutex_);
  auto it = writers_.find(channel);
  if (it != writers_.end()) return it->second;
  auto topic = topicFor(channel);
  if (!topic) return topic;
  dds_qos_t* qos = qosFor(channel, true);
  const dds_entity_t writer = dds_create_writer(participant_, *topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0) return Result<dds_entity_t>::failure(ddsError("dds_create_writer", writer));
  writers_.emplace(channel, writer);
  return writer;
}

Status DdsTransport::publish(const std::string& channel, const uint8_t* data, size_t size) {
  if (size > UINT32_MAX) return Status::failure("message too large for DDS");
  auto writer = writerFor(channel);
  if (!writer) {
    stats_.send_errors.fetch_add(1, std::memory_order_relaxed);
    return Status::failure(writer.error());
  }
  rgbdmap_Envelope msg;
  msg.data._maximum = msg.data._length = static_cast<uint32_t>(size);
  msg.data._buffer = const_cast<uint8_t*>(data);  // dds_write serialises; the buffer is not kept
  msg.data._release = false;
  const dds_return_t rc = dds_write(*writer, &msg);
  if (rc != DDS_RETCODE_OK) {
    stats_.send_errors.fetch_add(1, std::memory_order_relaxed);
    uint64_t suppressed = 0;
    if (g_dds_log.allow(&suppressed)) {
      log::warn("dds_write on ", channel, ": ", dds_strretcode(rc), " (", suppressed, " suppressed)");
    }
    return Status::failure(ddsError("dds_write", rc));
  }
  stats_.onSent(size);
  return Status::success();
}

std::optional<SubscriberMatch> DdsTransport::matchedSubscribers(const std::string& channel) {
  SubscriberMatch match;
  auto writer = writerFor(channel);
  dds_publication_matched_status_t status{};
  if (!writer || dds_get_publication_matched_status(*writer, &status) != DDS_RETCODE_OK) return match;
  match.current = static_cast<int>(status.current_count);
  match.total = status.total_count;
  return match;
}

Status DdsTransport::subscribe(const std::string& channel, Handler handler) {
  if (channel.empty() || !handler) return Status::failure("subscribe needs a channel and a handler");
  std::lock_guard<std::mutex> lock(entities_mutex_);
  if (channel.back() == '*') {
    if (Status s = watchPublications(); !s) return s;
    handlers_.add(channel, std::move(handler));
    prefixes_.push_back(channel);
    return Status::success();
  }
  // The handler is in place before the waitset can report the reader's first sample.
  handlers_.add(channel, std::move(handler));
  if (readers_.count(channel) != 0) return Status::success();
  return createReader(channel);
}

Status DdsTransport::createReader(const std::string& channel) {
  auto topic = topicFor(channel);
  if (!topic) return Status::failure(topic.error());
  dds_qos_t* qos = qosFor(channel, false);
  const dds_entity_t reader = dds_create_reader(participant_, *topic, qos, nullptr);
  dds_delete_qos(qos);
  if (reader < 0) return Status::failure(ddsError("dds_create_reader", reader));
  const dds_entity_t cond = dds_create_readcondition(reader, DDS_ANY_STATE);
  if (cond < 0) {
    dds_delete(reader);
    return Status::failure(ddsError("dds_create_readcondition", cond));
  }
  readers_.emplace(channel, reader);
  reader_channels_.emplace(reader, channel);
  const dds_return_t rc = dds_waitset_attach(waitset_, cond, static_cast<dds_attach_t>(reader));
  if (rc != DDS_RETCODE_OK) return Status::failure(ddsError("dds_waitset_attach", rc));
  return Status::success();
}

Status DdsTransport::watchPublications() {
  if (publications_ > 0) return Status::success();
  const dds_entity_t reader =
      dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  if (reader < 0) return Status::failure(ddsError("dds_create_reader(DCPSPublication)", reader));
  const dds_entity_t cond = dds_create_readcondition(reader, DDS_ANY_STATE);
  if (cond < 0 || dds_waitset_attach(waitset_, cond, static_cast<dds_attach_t>(reader)) != DDS_RETCODE_OK) {
    dds_delete(reader);
    return Status::failure("could not watch the DDS publications");
  }
  publications_ = reader;
  return Status::success();
}

void DdsTransport::discover() {
  dds_guid_t own;
  if (dds_get_guid(participant_, &own) != DDS_RETCODE_OK) return;
  constexpr int kBatch = 16;
  for (;;) {
    void* samples[kBatch] = {nullptr};
    dds_sample_info_t infos[kBatch];
    const dds_entity_t reader = publications_.load();
    const dds_return_t n = dds_take(reader, samples, infos, kBatch, kBatch);
    if (n <= 0) break;
    std::lock_guard<std::mutex> lock(entities_mutex_);
    for (dds_return_t i = 0; i < n; ++i) {
      const auto* p = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      std::string channel;
      if (!infos[i].valid_data || !p->topic_name || !p->type_name ||
          std::memcmp(&p->participant_key, &own, sizeof own) == 0 ||
          std::strcmp(p->type_name, rgbdmap_Envelope_desc.m_typename) != 0 ||
          !channelFromDdsTopic(p->topic_name, &channel) || readers_.count(channel) != 0)
        continue;
      const bool wanted = std::any_of(prefixes_.begin(), prefixes_.end(), [&](const std::string& prefix) {
        return channelMatches(prefix, channel);
      });
      if (!wanted) continue;
      if (discovered_readers_ >= kMaxDiscoveredReaders) {
        uint64_t suppressed = 0;
        if (g_dds_log.allow(&suppressed))
          log::warn("dds: not reading ", channel, ": ", kMaxDiscoveredReaders, " topics read already");
        continue;
      }
      if (const Status s = createReader(channel); !s) {
        log::warn("dds: cannot read ", channel, ": ", s.error());
        continue;
      }
      ++discovered_readers_;
    }
    dds_return_loan(reader, samples, n);
    if (n < kBatch) break;
  }
}

Status DdsTransport::start() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (thread_.joinable()) return Status::success();
  stopping_ = false;
  dds_set_guardcondition(guard_, false);
  thread_ = std::thread([this] { receiveLoop(); });
  return Status::success();
}

void DdsTransport::stop() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (!thread_.joinable()) return;
  stopping_ = true;
  dds_set_guardcondition(guard_, true);
  thread_.join();
}

void DdsTransport::receiveLoop() {
  dds_attach_t triggered[64];
  while (!stopping_) {
    const dds_return_t n = dds_waitset_wait(waitset_, triggered, 64, DDS_INFINITY);
    if (stopping_) return;
    if (n < 0) {
      log::error("dds_waitset_wait: ", dds_strretcode(n));
      return;
    }
    for (dds_return_t i = 0; i < n && i < 64; ++i) {
      if (triggered[i] == kGuardAttach) continue;
      if (const dds_entity_t p = publications_.load(); p > 0 && triggered[i] == static_cast<dds_attach_t>(p))
        discover();
      else
        drain(static_cast<dds_entity_t>(triggered[i]));
    }
  }
}

void DdsTransport::drain(dds_entity_t reader) {
  std::string channel;
  {
    std::lock_guard<std::mutex> lock(entities_mutex_);
    auto it = reader_channels_.find(reader);
    if (it == reader_channels_.end()) return;
    channel = it->second;
  }
  const auto handlers = handlers_.matching(channel);
  constexpr int kBatch = 16;
  for (;;) {
    void* samples[kBatch] = {nullptr};
    dds_sample_info_t infos[kBatch];
    const dds_return_t n = dds_take(reader, samples, infos, kBatch, kBatch);
    if (n <= 0) break;
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* msg = static_cast<const rgbdmap_Envelope*>(samples[i]);
      stats_.onReceived(msg->data._length);
      for (const auto& h : handlers) (*h)(channel, msg->data._buffer, msg->data._length);
    }
    dds_return_loan(reader, samples, n);
    if (n < kBatch) break;
  }
  dds_sample_lost_status_t lost;
  if (dds_get_sample_lost_status(reader, &lost) == DDS_RETCODE_OK && lost.total_count_change > 0) {
    stats_.dropped.fetch_add(static_cast<uint64_t>(lost.total_count_change), std::memory_order_relaxed);
  }
}

}  // namespace rgbdmap::transport
