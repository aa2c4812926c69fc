#include "rgbdmap/intake/chunk_reassembly.hpp"

#include <algorithm>
#include <cstring>

namespace rgbdmap {
namespace {

msg::Bytes allOnes(int count) {
  msg::Bytes bits(static_cast<size_t>((count + 7) / 8), 0);
  for (int i = 0; i < count; ++i) bits[static_cast<size_t>(i / 8)] |= static_cast<uint8_t>(1u << (i % 8));
  return bits;
}

}  // namespace

ChunkReassembly::Outcome ChunkReassembly::add(const std::string& robot, const msg::KeyframeChunk& chunk,
                                              Clock::time_point now, std::vector<uint8_t>* complete) {
  ++stats_.chunks;
  RobotState& state = robots_[robot];
  if (chunk.header.session != state.session) {
    clear(state);
    state.session = chunk.header.session;
  }
  for (const Completed& done : state.completed) {
    if (done.transfer_id != chunk.transfer_id) continue;
    const bool same = done.keyframe_id == chunk.keyframe_id && done.chunk_count == chunk.chunk_count &&
                      done.total_bytes == chunk.total_bytes;
    ++(same ? stats_.duplicates : stats_.refused);
    return same ? Outcome::kDuplicate : Outcome::kRefused;
  }
  auto it = state.transfers.find(chunk.transfer_id);
  if (it == state.transfers.end()) {
    const size_t bytes = static_cast<size_t>(chunk.total_bytes);
    if (!makeRoom(state, bytes)) {
      ++stats_.refused;
      return Outcome::kRefused;
    }
    Transfer t;
    t.keyframe_id = chunk.keyframe_id;
    t.chunk_count = chunk.chunk_count;
    t.chunk_bytes = chunk.chunk_bytes;
    t.total_bytes = chunk.total_bytes;
    t.data.resize(bytes);
    t.received.assign(static_cast<size_t>(chunk.chunk_count), false);
    state.bytes += bytes;
    total_bytes_ += bytes;
    it = state.transfers.emplace(chunk.transfer_id, std::move(t)).first;
  }
  Transfer& t = it->second;
  if (t.keyframe_id != chunk.keyframe_id || t.chunk_count != chunk.chunk_count ||
      t.chunk_bytes != chunk.chunk_bytes || t.total_bytes != chunk.total_bytes) {
    ++stats_.refused;
    return Outcome::kRefused;
  }
  t.last_chunk = now;
  const size_t index = static_cast<size_t>(chunk.chunk_index);
  if (t.received[index]) {
    ++stats_.duplicates;
    return Outcome::kDuplicate;
  }
  // validate() guarantees offset + size <= total_bytes.
  std::memcpy(t.data.data() + index * static_cast<size_t>(t.chunk_bytes), chunk.data.data(),
              chunk.data.size());
  t.received[index] = true;
  if (++t.received_count < t.chunk_count) return Outcome::kStored;
  *complete = std::move(t.data);
  state.completed.push_back(Completed{chunk.transfer_id, t.keyframe_id, t.chunk_count, t.total_bytes});
  if (state.completed.size() > options_.completed_remembered) state.completed.pop_front();
  erase(state, it);
  ++stats_.completed;
  return Outcome::kComplete;
}

bool ChunkReassembly::makeRoom(RobotState& state, size_t bytes) {
  if (bytes > options_.max_bytes_per_robot || options_.max_transfers_per_robot == 0) return false;
  while (!state.transfers.empty() && (state.transfers.size() >= options_.max_transfers_per_robot ||
                                      state.bytes + bytes > options_.max_bytes_per_robot)) {
    auto oldest = std::min_element(
        state.transfers.begin(), state.transfers.end(),
        [](const auto& a, const auto& b) { return a.second.last_chunk < b.second.last_chunk; });
    erase(state, oldest);
    ++stats_.evicted;
  }
  return total_bytes_ + bytes <= options_.max_total_bytes;
}

void ChunkReassembly::clear(RobotState& state) {
  while (!state.transfers.empty()) erase(state, state.transfers.begin());
  state.completed.clear();
}

void ChunkReassembly::erase(RobotState& state, std::map<int64_t, Transfer>::iterator it) {
  state.bytes -= static_cast<size_t>(it->second.total_bytes);
  total_bytes_ -= static_cast<size_t>(it->second.total_bytes);
  state.transfers.erase(it);
}

std::optional<msg::Bytes> ChunkReassembly::receivedBitmap(const std::string& robot,
                                                          int64_t transfer_id) const {
  const auto r = robots_.find(robot);
  if (r == robots_.end()) return std::nullopt;
  for (const Completed& done : r->second.completed)
    if (done.transfer_id == transfer_id) return allOnes(done.chunk_count);
  const auto it = r->second.transfers.find(transfer_id);
  if (it == r->second.transfers.end()) return std::nullopt;
  const Transfer& t = it->second;
  msg::Bytes bits(static_cast<size_t>((t.chunk_count + 7) / 8), 0);
  for (int i = 0; i < t.chunk_count; ++i)
    if (t.received[static_cast<size_t>(i)])
      bits[static_cast<size_t>(i / 8)] |= static_cast<uint8_t>(1u << (i % 8));
  return bits;
}

void ChunkReassembly::evictStale(Clock::time_point now) {
  const auto timeout =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.timeout_s));
  for (auto& [robot, state] : robots_) {
    for (auto it = state.transfers.begin(); it != state.transfers.end();) {
      auto next = std::next(it);
      if (now - it->second.last_chunk > timeout) {
        erase(state, it);
        ++stats_.timed_out;
      }
      it = next;
    }
  }
}

size_t ChunkReassembly::transfersInProgress() const {
  size_t n = 0;
  for (const auto& [robot, state] : robots_) n += state.transfers.size();
  return n;
}

size_t ChunkReassembly::bytesInProgress() const { return total_bytes_; }

}  // namespace rgbdmap
