#include "rgbdmap/store/map_store.hpp"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <unordered_map>
#include <utility>

#include "log_scan.hpp"
#include "rgbdmap/common/logging.hpp"
#include "store_codec.hpp"
#include "store_files.hpp"

namespace rgbdmap {
namespace {

constexpr const char* kKeyframeLog = "keyframes.log";
constexpr const char* kLoopLog = "loops.log";
constexpr size_t kMaxProblemsLogged = 20;

struct RecordLocation {
  int64_t offset = 0;
  int64_t size = 0;  ///< header + payload
};

/// One append-only log: its descriptor and where the next record goes.
struct LogFile {
  store::UniqueFd fd;
  std::string path;
  std::atomic<int64_t> end{0};
};

/// What the in-memory list keeps of a keyframe: everything but the images and the features (~55 KB of a
/// keyframe's ~60 KB in RAM otherwise); readKeyframe() has them.
/// What keyframes() keeps: the keyframe without its images and features, copied field by field (a whole
/// copy would copy ~100 KB of blobs on every append).
StoredKeyframe withoutPayload(const StoredKeyframe& k) {
  StoredKeyframe m{k.node_id, k.session, {}};
  const msg::Keyframe& s = k.keyframe;
  m.keyframe.header = s.header;
  m.keyframe.robot_id = s.robot_id;
  m.keyframe.segment_id = s.segment_id;
  m.keyframe.keyframe_id = s.keyframe_id;
  m.keyframe.timestamp = s.timestamp;
  m.keyframe.T_odom_cam = s.T_odom_cam;
  m.keyframe.previous_keyframe_id = s.previous_keyframe_id;
  m.keyframe.T_prev_cur = s.T_prev_cur;
  m.keyframe.information = s.information;
  m.keyframe.images.width = s.images.width;
  m.keyframe.images.height = s.images.height;
  m.keyframe.images.color_codec = s.images.color_codec;
  return m;
}

/// A record read back from a log: its bytes, the payload after the header, verified (header and CRC).
struct ReadRecord {
  msg::Bytes bytes;
  uint32_t payload_size = 0;
  const uint8_t* payload() const { return bytes.data() + store::kRecordHeaderSize; }
};

/// Reads the record at `where` and verifies it is one of `type`; errors start with `context`.
Result<ReadRecord> readRecord(const LogFile& log, const RecordLocation& where, store::RecordType type,
                              const std::string& context) {
  using R = Result<ReadRecord>;
  ReadRecord r;
  r.bytes.resize(static_cast<size_t>(where.size));
  if (Status s = store::readAt(log.fd.get(), r.bytes.data(), r.bytes.size(), where.offset, log.path); !s)
    return R::failure(s.error());
  const std::optional<store::RecordHeader> header = store::parseRecordHeader(r.bytes.data());
  if (!header || header->payload_size + store::kRecordHeaderSize != r.bytes.size())
    return R::failure(context + "record header no longer verifies");
  if (Status s = store::verifyRecord(*header, type, r.payload()); !s) return R::failure(context + s.error());
  r.payload_size = header->payload_size;
  return r;
}

}  // namespace

struct MapStore::State {
  std::string dir;
  MapStoreOptions options;
  store::UniqueFd lock;
  LogFile keyframe_log, loop_log;
  std::vector<StoredKeyframe> keyframes;
  std::vector<StoredLoop> loops;             ///< without their inlier pairs (readLoopPairs)
  std::vector<RecordLocation> loop_records;  ///< loops[i]'s record in loop_log (guarded by index_mutex)
  MapStoreRecovery recovery;

  std::mutex append_mutex;  ///< serialises appends and recover(); guards `failed`
  std::string failed;       ///< set by an append that hit an I/O error: the log state is no longer known
  mutable std::mutex health_mutex;  ///< `health` (taken inside append_mutex, never the other way)
  MapStoreHealth health;
  mutable std::mutex index_mutex;
  std::unordered_map<int64_t, RecordLocation> index;  ///< node id -> keyframe record

  bool hasNode(int64_t node_id) const {
    std::lock_guard<std::mutex> lock(index_mutex);
    return index.count(node_id) > 0;
  }
  Status load(LogFile* log, store::RecordType type, const store::RecordVisitor& visit);
  Status loadKeyframes();
  Status loadLoops();
  /// Keeps a loop in memory without its pairs (they are read back from its record).
  void keepLoop(StoredLoop loop, const RecordLocation& record) {
    loop.inlier_pairs = {};
    loops.push_back(std::move(loop));
    std::lock_guard<std::mutex> lock(index_mutex);
    loop_records.push_back(record);
  }
  Status append(LogFile* log, const msg::Bytes& record);
  // recover(): caller holds append_mutex
  Status cutToEnd(LogFile* log);
  Status probeSpace(LogFile* log);
  void noteHealth(const std::string& error, bool new_failure, bool attempt);
  Status failedStatus() const {
    return Status::failure("map store failed (" + failed + "): no appends until it recovers");
  }
};

Status MapStore::State::load(LogFile* log, store::RecordType type, const store::RecordVisitor& visit) {
  Result<int64_t> size = store::fileSize(log->fd.get(), log->path);
  if (!size) return Status::failure(size.error());
  Result<store::ScanReport> scan = store::scanLog(log->fd.get(), *size, type, log->path, visit);
  if (!scan) return Status::failure(scan.error());
  if (scan->valid_end < *size) {  // repair: the next append starts at a record boundary
    if (Status s = store::truncateTo(log->fd.get(), scan->valid_end, log->path); !s) return s;
    if (options.sync)
      if (Status s = store::syncData(log->fd.get(), log->path); !s) return s;
  }
  log->end = scan->valid_end;
  recovery.corrupt_records += scan->corrupt_records;
  recovery.truncated_bytes += scan->truncated_bytes;
  for (std::string& p : scan->problems) recovery.problems.push_back(std::move(p));
  return Status::success();
}

Status MapStore::State::loadKeyframes() {
  return load(&keyframe_log, store::RecordType::kKeyframe,
              [this](int64_t offset, const uint8_t* payload, size_t size) -> Status {
                Result<StoredKeyframe> k = store::decodeKeyframePayload(payload, size);
                if (!k) return Status::failure(k.error());
                if (index.count(k->node_id))
                  return Status::failure("duplicate node id " + std::to_string(k->node_id));
                index[k->node_id] = {offset, static_cast<int64_t>(store::kRecordHeaderSize + size)};
                keyframes.push_back(withoutPayload(*k));
                return Status::success();
              });
}

Status MapStore::State::loadLoops() {
  return load(
      &loop_log, store::RecordType::kLoop, [this](int64_t offset, const uint8_t* payload, size_t size) {
        Result<StoredLoop> loop = store::decodeLoopPayload(payload, size);
        if (!loop) return Status::failure(loop.error());
        if (!index.count(loop->from_node) || !index.count(loop->to_node))
          return Status::failure("loop " + std::to_string(loop->from_node) + " -> " +
                                 std::to_string(loop->to_node) + " refers to a node that is not stored");
        keepLoop(std::move(loop).value(), {offset, static_cast<int64_t>(store::kRecordHeaderSize + size)});
        return Status::success();
      });
}

Status MapStore::State::append(LogFile* log, const msg::Bytes& record) {
  const int64_t offset = log->end;
  Status s = store::writeAt(log->fd.get(), record.data(), record.size(), offset, log->path);
  if (s && options.sync) s = store::syncData(log->fd.get(), log->path);
  if (!s) {
    // Cut a partial record off so the file still ends at a record boundary; after an I/O error (above all
    // a failed fdatasync) what the file holds is not known, so this store takes no more appends.
    (void)store::truncateTo(log->fd.get(), offset, log->path);
    failed = s.error();
    noteHealth(failed, true, false);
    log::error("map store '", dir, "': append failed, no further appends until it recovers: ", s.error());
    return s;
  }
  log->end = offset + static_cast<int64_t>(record.size());
  return Status::success();
}

void MapStore::State::noteHealth(const std::string& error, bool new_failure, bool attempt) {
  std::lock_guard<std::mutex> lock(health_mutex);
  health.failed = !error.empty();
  health.error = error;
  if (new_failure) ++health.failures;
  if (attempt) ++health.recover_attempts;
  if (attempt && error.empty()) ++health.recoveries;
}

/// Cuts whatever a failed append left past the last acknowledged record and makes the length durable.
Status MapStore::State::cutToEnd(LogFile* log) {
  const int64_t end = log->end;
  if (Status s = store::truncateTo(log->fd.get(), end, log->path); !s) return s;
  if (options.sync)
    if (Status s = store::syncData(log->fd.get(), log->path); !s) return s;
  Result<int64_t> size = store::fileSize(log->fd.get(), log->path);
  if (!size) return Status::failure(size.error());
  if (*size != end)
    return Status::failure("'" + log->path + "' holds " + std::to_string(*size) +
                           " bytes after cutting it to " + std::to_string(end));
  return Status::success();
}

/// Writes and syncs zeros past the end, then cuts them off: fails while appends would not fit. (Killed in
/// between, the zeros are a damaged tail that open() cuts off.)
Status MapStore::State::probeSpace(LogFile* log) {
  const int64_t end = log->end;
  const std::vector<uint8_t> zeros(static_cast<size_t>(std::max<int64_t>(0, options.recover_probe_bytes)));
  Status s = store::writeAt(log->fd.get(), zeros.data(), zeros.size(), end, log->path);
  if (s && options.sync) s = store::syncData(log->fd.get(), log->path);
  const Status cut = cutToEnd(log);
  return s ? cut : s;
}

Result<std::unique_ptr<MapStore>> MapStore::open(const std::string& dir, MapStoreOptions options) {
  using R = Result<std::unique_ptr<MapStore>>;
  if (dir.empty()) return R::failure("map store: empty directory name");
  auto state = std::make_unique<State>();
  state->dir = dir;
  state->options = options;
  if (Status s = store::makeDirectory(dir); !s) return R::failure(s.error());
  Result<store::UniqueFd> lock = store::lockDirectory(dir);
  if (!lock) return R::failure(lock.error());
  state->lock = std::move(lock).value();
  if (Status s = store::checkOrCreateManifest(dir, kKeyframeLog); !s) return R::failure(s.error());
  for (auto [log, name] :
       {std::pair{&state->keyframe_log, kKeyframeLog}, std::pair{&state->loop_log, kLoopLog}}) {
    Result<store::UniqueFd> fd = store::openLog(dir, name);
    if (!fd) return R::failure(fd.error());
    log->fd = std::move(fd).value();
    log->path = dir + "/" + name;
  }
  if (Status s = state->loadKeyframes(); !s) return R::failure(s.error());
  if (Status s = state->loadLoops(); !s) return R::failure(s.error());

  MapStoreRecovery& r = state->recovery;
  r.keyframes = static_cast<int>(state->keyframes.size());
  r.loops = static_cast<int>(state->loops.size());
  for (size_t i = 0; i < r.problems.size() && i < kMaxProblemsLogged; ++i)
    log::warn("map store: ", r.problems[i]);
  if (r.problems.size() > kMaxProblemsLogged)
    log::warn("map store: ", r.problems.size() - kMaxProblemsLogged, " more problems not logged");
  log::info("map store '", dir, "': ", r.keyframes, " keyframes, ", r.loops, " loops, ", r.corrupt_records,
            " corrupt records skipped, ", r.truncated_bytes, " bytes of incomplete tail cut off");
  return std::unique_ptr<MapStore>(new MapStore(std::move(state)));
}

MapStore::MapStore(std::unique_ptr<State> state) : state_(std::move(state)) {}
MapStore::~MapStore() = default;

Status MapStore::appendKeyframe(const StoredKeyframe& keyframe) {
  Result<msg::Bytes> payload = store::encodeKeyframePayload(keyframe);
  if (!payload) return Status::failure(payload.error());
  return appendEncodedKeyframe(keyframe, *payload);
}

Status MapStore::appendKeyframePayload(const msg::Bytes& payload) {
  Result<StoredKeyframe> keyframe = store::decodeKeyframePayload(payload.data(), payload.size());
  if (!keyframe) return Status::failure(keyframe.error());
  return appendEncodedKeyframe(*keyframe, payload);
}

Status MapStore::appendEncodedKeyframe(const StoredKeyframe& keyframe, const msg::Bytes& payload) {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.append_mutex);
  if (!s.failed.empty()) return s.failedStatus();
  if (keyframe.node_id < 0) return Status::failure("negative node id " + std::to_string(keyframe.node_id));
  if (s.hasNode(keyframe.node_id))
    return Status::failure("duplicate node id " + std::to_string(keyframe.node_id) + ": already stored");
  const msg::Bytes record = store::frameRecord(store::RecordType::kKeyframe, payload);
  const int64_t offset = s.keyframe_log.end;
  if (Status st = s.append(&s.keyframe_log, record); !st) return st;
  {
    std::lock_guard<std::mutex> index_lock(s.index_mutex);
    s.index[keyframe.node_id] = {offset, static_cast<int64_t>(record.size())};
  }
  s.keyframes.push_back(withoutPayload(keyframe));
  return Status::success();
}

Status MapStore::appendLoop(const StoredLoop& loop) {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.append_mutex);
  if (!s.failed.empty()) return s.failedStatus();
  Result<msg::Bytes> payload = store::encodeLoopPayload(loop);
  if (!payload) return Status::failure(payload.error());
  for (int64_t node : {loop.from_node, loop.to_node})
    if (!s.hasNode(node)) return Status::failure("loop refers to unknown node id " + std::to_string(node));
  const msg::Bytes record = store::frameRecord(store::RecordType::kLoop, *payload);
  const int64_t offset = s.loop_log.end;
  if (Status st = s.append(&s.loop_log, record); !st) return st;
  s.keepLoop(loop, {offset, static_cast<int64_t>(record.size())});
  return Status::success();
}

Status MapStore::appendLoops(const std::vector<StoredLoop>& loops) {
  if (loops.empty()) return Status::success();
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.append_mutex);
  if (!s.failed.empty()) return s.failedStatus();
  msg::Bytes records;
  std::vector<RecordLocation> where;
  const int64_t offset = s.loop_log.end;
  for (const StoredLoop& loop : loops) {
    Result<msg::Bytes> payload = store::encodeLoopPayload(loop);
    if (!payload) return Status::failure(payload.error());
    for (int64_t node : {loop.from_node, loop.to_node})
      if (!s.hasNode(node)) return Status::failure("loop refers to unknown node id " + std::to_string(node));
    const msg::Bytes record = store::frameRecord(store::RecordType::kLoop, *payload);
    where.push_back({offset + static_cast<int64_t>(records.size()), static_cast<int64_t>(record.size())});
    records.insert(records.end(), record.begin(), record.end());
  }
  if (Status st = s.append(&s.loop_log, records); !st) return st;
  for (size_t i = 0; i < loops.size(); ++i) s.keepLoop(loops[i], where[i]);
  return Status::success();
}

Status MapStore::recover() {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.append_mutex);
  if (s.failed.empty()) return Status::success();
  Status st = s.cutToEnd(&s.keyframe_log);
  if (st) st = s.cutToEnd(&s.loop_log);
  if (st) st = s.probeSpace(&s.keyframe_log);
  if (!st) {
    s.noteHealth("recovery failed: " + st.error() + " (appends stopped on: " + s.failed + ")", false, true);
    return st;
  }
  log::info("map store '", s.dir, "': appends work again (they stopped on: ", s.failed, ")");
  s.failed.clear();
  s.noteHealth("", false, true);
  return Status::success();
}

MapStoreHealth MapStore::health() const {
  std::lock_guard<std::mutex> lock(state_->health_mutex);
  return state_->health;
}

Result<StoredKeyframe> MapStore::readKeyframe(int64_t node_id) const {
  auto read = readVerifiedKeyframe(node_id, false);
  if (!read) return Result<StoredKeyframe>::failure(read.error());
  return std::move(read->second);
}

Result<msg::Bytes> MapStore::readKeyframePayload(int64_t node_id) const {
  auto read = readVerifiedKeyframe(node_id, true);
  if (!read) return Result<msg::Bytes>::failure(read.error());
  return std::move(read->first);
}

Result<std::pair<msg::Bytes, StoredKeyframe>> MapStore::readVerifiedKeyframe(int64_t node_id,
                                                                             bool keep_payload) const {
  using R = Result<std::pair<msg::Bytes, StoredKeyframe>>;
  RecordLocation where;
  {
    std::lock_guard<std::mutex> lock(state_->index_mutex);
    auto it = state_->index.find(node_id);
    if (it == state_->index.end()) return R::failure("unknown node id " + std::to_string(node_id));
    where = it->second;
  }
  const LogFile& log = state_->keyframe_log;
  const std::string context = "keyframe " + std::to_string(node_id) + " at offset " +
                              std::to_string(where.offset) + " of '" + log.path + "': ";
  Result<ReadRecord> record = readRecord(log, where, store::RecordType::kKeyframe, context);
  if (!record) return R::failure(record.error());
  Result<StoredKeyframe> k = store::decodeKeyframePayload(record->payload(), record->payload_size);
  if (!k) return R::failure(context + k.error());
  if (k->node_id != node_id)
    return R::failure(context + "record holds node id " + std::to_string(k->node_id));
  msg::Bytes payload;
  if (keep_payload) payload.assign(record->payload(), record->payload() + record->payload_size);
  return std::make_pair(std::move(payload), std::move(*k));
}

Result<std::vector<std::pair<int, int>>> MapStore::readLoopPairs(size_t i) const {
  using R = Result<std::vector<std::pair<int, int>>>;
  RecordLocation where;
  {
    std::lock_guard<std::mutex> lock(state_->index_mutex);
    if (i >= state_->loop_records.size()) return R::failure("no stored loop " + std::to_string(i));
    where = state_->loop_records[i];
  }
  const LogFile& log = state_->loop_log;
  const std::string context =
      "loop " + std::to_string(i) + " at offset " + std::to_string(where.offset) + " of '" + log.path + "': ";
  Result<ReadRecord> record = readRecord(log, where, store::RecordType::kLoop, context);
  if (!record) return R::failure(record.error());
  Result<StoredLoop> loop = store::decodeLoopPayload(record->payload(), record->payload_size);
  if (!loop) return R::failure(context + loop.error());
  return std::move(loop->inlier_pairs);
}

const std::vector<StoredKeyframe>& MapStore::keyframes() const { return state_->keyframes; }
const std::vector<StoredLoop>& MapStore::loops() const { return state_->loops; }
const MapStoreRecovery& MapStore::recovery() const { return state_->recovery; }
int64_t MapStore::bytesOnDisk() const { return state_->keyframe_log.end + state_->loop_log.end; }
const std::string& MapStore::directory() const { return state_->dir; }

}  // namespace rgbdmap
