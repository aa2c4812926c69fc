// KeyframeSpool: one file per keyframe, written atomically, deleted when answered (keyframe_spool.hpp).
#include "rgbdmap/link/keyframe_spool.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "wall_clock.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[] = "RKSP";
constexpr uint16_t kVersion = 1;
constexpr size_t kHeaderBytes = 28;  ///< 24 bytes of fields + their CRC
constexpr int kIdBlock = 256;        ///< keyframe ids reserved in SPOOL at a time
constexpr int kSegmentBlock = 16;
constexpr char kStateHeader[] = "rgbdmap keyframe spool 1";

uint32_t crc32Of(const void* data, size_t size) {
  return static_cast<uint32_t>(
      crc32(crc32(0L, Z_NULL, 0), static_cast<const Bytef*>(data), static_cast<uInt>(size)));
}

void putLe(std::string* out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

uint64_t getLe(const std::string& in, size_t at, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= uint64_t{static_cast<uint8_t>(in[at + i])} << (8 * i);
  return v;
}

/// "kf-<digits>.rec" -> the id; -1 for any other name.
int recordId(const std::string& name) {
  if (name.size() < 8 || name.rfind("kf-", 0) != 0 || name.substr(name.size() - 4) != ".rec") return -1;
  const std::string digits = name.substr(3, name.size() - 7);
  if (digits.empty() || digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), ::isdigit)) return -1;
  return std::stoi(digits);
}

Result<std::string> readWhole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Result<std::string>::failure("cannot read " + path + ": " + std::strerror(errno));
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

struct SpoolState {
  std::string robot;
  int64_t session = 0;
  int reserved_id = 0, reserved_segment = 0;
};

Result<SpoolState> parseState(const std::string& text) {
  std::istringstream in(text);
  std::string line, key;
  if (!std::getline(in, line) || line != kStateHeader)
    return Result<SpoolState>::failure("not a keyframe spool state (first line '" + line + "')");
  SpoolState s;
  bool robot = false, session = false, id = false, segment = false;
  while (in >> key) {
    if (key == "robot")
      robot = static_cast<bool>(in >> s.robot);
    else if (key == "session")
      session = static_cast<bool>(in >> s.session);
    else if (key == "reserved_keyframe_id")
      id = static_cast<bool>(in >> s.reserved_id);
    else if (key == "reserved_segment")
      segment = static_cast<bool>(in >> s.reserved_segment);
    else
      return Result<SpoolState>::failure("unknown key '" + key + "'");
  }
  if (!robot || !session || !id || !segment || s.session <= 0 || s.reserved_id < 0 || s.reserved_segment < 0)
    return Result<SpoolState>::failure("incomplete or invalid state");
  return s;
}

}  // namespace

Result<std::string> encodeSpoolRecord(int64_t session, msg::Keyframe keyframe) {
  keyframe.header.sender = keyframe.robot_id;  // the link stamps the rest of the header when it seals
  Result<msg::Bytes> payload = msg::encodePayload(keyframe);
  if (!payload) return Result<std::string>::failure(payload.error());
  std::string out(kMagic, 4);
  putLe(&out, kVersion, 2);
  putLe(&out, 0, 2);
  putLe(&out, static_cast<uint64_t>(session), 8);
  putLe(&out, payload->size(), 4);
  putLe(&out, crc32Of(payload->data(), payload->size()), 4);
  putLe(&out, crc32Of(out.data(), out.size()), 4);
  out.append(reinterpret_cast<const char*>(payload->data()), payload->size());
  return out;
}

Result<msg::Keyframe> decodeSpoolRecord(const std::string& bytes, int64_t* session) {
  using R = Result<msg::Keyframe>;
  if (bytes.size() < kHeaderBytes)
    return R::failure("truncated header (" + std::to_string(bytes.size()) + " bytes)");
  if (bytes.compare(0, 4, kMagic) != 0) return R::failure("bad magic");
  if (getLe(bytes, 24, 4) != crc32Of(bytes.data(), 24)) return R::failure("header checksum mismatch");
  if (getLe(bytes, 4, 2) != kVersion)
    return R::failure("unknown record version " + std::to_string(getLe(bytes, 4, 2)));
  const uint64_t length = getLe(bytes, 16, 4);
  if (length != bytes.size() - kHeaderBytes)
    return R::failure("length " + std::to_string(length) + " but " +
                      std::to_string(bytes.size() - kHeaderBytes) + " payload bytes");
  const auto* payload = reinterpret_cast<const uint8_t*>(bytes.data()) + kHeaderBytes;
  if (getLe(bytes, 20, 4) != crc32Of(payload, length)) return R::failure("payload checksum mismatch");
  R keyframe = msg::decodePayload<msg::Keyframe>(payload, length);
  if (!keyframe) return R::failure("payload: " + keyframe.error());
  *session = static_cast<int64_t>(getLe(bytes, 8, 8));
  return keyframe;
}

KeyframeSpool::KeyframeSpool(KeyframeSpoolOptions options, std::string robot_id)
    : options_(std::move(options)), robot_id_(std::move(robot_id)) {}

KeyframeSpool::~KeyframeSpool() {
  if (lock_fd_ >= 0) ::close(lock_fd_);  // releases the flock
}

Result<std::unique_ptr<KeyframeSpool>> KeyframeSpool::open(const KeyframeSpoolOptions& options,
                                                           const std::string& robot_id) {
  using R = Result<std::unique_ptr<KeyframeSpool>>;
  std::error_code ec;
  fs::create_directories(options.directory, ec);
  if (ec) return R::failure("keyframe spool " + options.directory + ": cannot create: " + ec.message());
  std::unique_ptr<KeyframeSpool> spool(new KeyframeSpool(options, robot_id));
  if (Status s = spool->lockFolder(); !s) return R::failure(s.error());
  if (Status s = spool->scan(); !s) return R::failure(s.error());
  return spool;
}

Status KeyframeSpool::lockFolder() {
  const std::string path = options_.directory + "/LOCK";
  lock_fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0)
    return Status::failure("keyframe spool: cannot open " + path + ": " + std::strerror(errno));
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0)
    return Status::failure("keyframe spool " + options_.directory +
                           " is in use by another process (is robot " + robot_id_ + " running already?)");
  return Status::success();
}

void KeyframeSpool::moveAside(const std::string& name, const std::string& reason) {
  ++stats_.damaged;
  log::warn("keyframe spool ", options_.directory, ": ", name, " is damaged (", reason,
            "): moved to damaged/, not sent");
  std::error_code ec;
  fs::create_directories(options_.directory + "/damaged", ec);
  fs::rename(options_.directory + "/" + name, options_.directory + "/damaged/" + name, ec);
  if (ec) fs::remove(options_.directory + "/" + name, ec);
}

Status KeyframeSpool::scan() {
  std::optional<SpoolState> state;
  const std::string state_path = options_.directory + "/SPOOL";
  if (fs::exists(state_path)) {
    Result<std::string> text = readWhole(state_path);
    Result<SpoolState> parsed = text ? parseState(*text) : Result<SpoolState>::failure(text.error());
    if (parsed && parsed->robot != robot_id_)
      return Status::failure("keyframe spool " + options_.directory + " belongs to robot '" + parsed->robot +
                             "', not '" + robot_id_ + "'");
    if (parsed)
      state = *parsed;
    else
      log::warn("keyframe spool ", state_path, ": ", parsed.error(),
                "; the session is taken from the records");
  }
  std::map<int, std::pair<std::string, int64_t>> found;  // id -> (name, session)
  int max_segment = -1;
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(options_.directory))
    if (entry.is_regular_file()) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  std::error_code ec;
  for (const std::string& name : names) {
    if (name.find(".tmp") != std::string::npos) {  // an interrupted atomic write
      fs::remove(options_.directory + "/" + name, ec);
      continue;
    }
    const int id = recordId(name);
    if (id < 0) continue;
    Result<std::string> bytes = readWhole(options_.directory + "/" + name);
    int64_t session = 0;
    Result<msg::Keyframe> kf =
        bytes ? decodeSpoolRecord(*bytes, &session) : Result<msg::Keyframe>::failure(bytes.error());
    if (kf && (kf->keyframe_id != id || kf->robot_id != robot_id_))
      kf = Result<msg::Keyframe>::failure("holds keyframe " + std::to_string(kf->keyframe_id) +
                                          " of robot '" + kf->robot_id + "'");
    const int64_t expected =
        state ? state->session : (found.empty() ? session : found.begin()->second.second);
    if (kf && session != expected)
      kf = Result<msg::Keyframe>::failure("of session " + std::to_string(session) + ", not the spool's " +
                                          std::to_string(expected));
    if (!kf) {
      moveAside(name, kf.error());
      continue;
    }
    found[id] = {name, session};
    max_segment = std::max(max_segment, kf->segment_id);
    struct stat st {};
    const std::string path = options_.directory + "/" + name;
    const int64_t utime = ::stat(path.c_str(), &st) == 0
                              ? int64_t{st.st_mtim.tv_sec} * 1000000 + st.st_mtim.tv_nsec / 1000
                              : nowUtime();
    entries_[id] = Entry{bytes->size(), utime};
    stats_.bytes += bytes->size();
  }
  stats_.recovered = stats_.depth = entries_.size();
  resumed_ = !entries_.empty();
  if (resumed_) {
    session_ = state ? state->session : found.begin()->second.second;
    first_seq_ = std::max<int64_t>(1, nowUtime() - session_);
    first_keyframe_id_ = std::max(state ? state->reserved_id : 0, entries_.rbegin()->first + 1);
    first_segment_ = std::max(state ? state->reserved_segment : 0, max_segment + 1);
    if (!state)
      log::warn("keyframe spool ", options_.directory, ": no valid SPOOL state; keyframe ids continue at ",
                first_keyframe_id_, " (an id already answered by the server would be taken as a duplicate)");
  } else {
    session_ = msg::newSessionId();
  }
  for (const auto& [id, e] : entries_)
    stats_.oldest_utime =
        stats_.oldest_utime == 0 ? e.spooled_utime : std::min(stats_.oldest_utime, e.spooled_utime);
  return writeState(first_keyframe_id_ + kIdBlock, first_segment_ + kSegmentBlock);
}

Status KeyframeSpool::writeState(int reserved_id, int reserved_segment) {
  std::ostringstream text;
  text << kStateHeader << "\nrobot " << robot_id_ << "\nsession " << session_ << "\nreserved_keyframe_id "
       << reserved_id << "\nreserved_segment " << reserved_segment << "\n";
  Status s = writeFileAtomic(options_.directory + "/SPOOL", text.str());
  if (!s) return Status::failure("keyframe spool: " + s.error());
  reserved_id_ = reserved_id;
  reserved_segment_ = reserved_segment;
  return s;
}

std::string KeyframeSpool::recordPath(int keyframe_id) const {
  char name[32];
  std::snprintf(name, sizeof(name), "kf-%09d.rec", keyframe_id);
  return options_.directory + "/" + name;
}

std::vector<int> KeyframeSpool::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<int> ids;
  ids.reserve(entries_.size());
  for (const auto& [id, e] : entries_) ids.push_back(id);
  return ids;
}

Status KeyframeSpool::append(const msg::Keyframe& keyframe) {
  const int id = keyframe.keyframe_id;
  if (id < first_keyframe_id_ || keyframe.segment_id < first_segment_ || keyframe.robot_id != robot_id_)
    return Status::failure("keyframe spool: keyframe " + std::to_string(id) + " (segment " +
                           std::to_string(keyframe.segment_id) + ") is not this process's");
  Result<std::string> record = encodeSpoolRecord(session_, keyframe);
  if (!record) return Status::failure("keyframe spool: " + record.error());
  std::unique_lock<std::mutex> lock(mutex_);
  if (entries_.count(id))
    return Status::failure("keyframe spool: keyframe " + std::to_string(id) + " is spooled already");
  if (stats_.bytes + record->size() > options_.max_bytes) {
    ++stats_.not_spooled;
    return Status::failure("keyframe spool full (" + std::to_string(stats_.bytes >> 20) + " of " +
                           std::to_string(options_.max_bytes >> 20) + " MiB)");
  }
  if (id >= reserved_id_ || keyframe.segment_id >= reserved_segment_) {
    // Reserved before the record exists: a later start never gives this id or segment to another keyframe.
    if (Status s = writeState(std::max(reserved_id_, id + kIdBlock),
                              std::max(reserved_segment_, keyframe.segment_id + kSegmentBlock));
        !s) {
      ++stats_.not_spooled, ++stats_.write_errors;
      return s;
    }
  }
  stats_.bytes += record->size();  // claimed while the file is written without the lock
  entries_[id] = Entry{record->size(), 0};
  lock.unlock();
  Status s = writeFileAtomic(recordPath(id), *record);
  lock.lock();
  if (!s) {
    stats_.bytes -= record->size();
    entries_.erase(id);
    ++stats_.not_spooled, ++stats_.write_errors;
    return Status::failure("keyframe spool: " + s.error());
  }
  entries_[id].spooled_utime = nowUtime();
  if (stats_.oldest_utime == 0) stats_.oldest_utime = entries_[id].spooled_utime;
  ++stats_.appended;
  stats_.depth = entries_.size();
  return Status::success();
}

Result<msg::Keyframe> KeyframeSpool::read(int keyframe_id) const {
  Result<std::string> bytes = readWhole(recordPath(keyframe_id));
  if (!bytes) return Result<msg::Keyframe>::failure(bytes.error());
  int64_t session = 0;
  Result<msg::Keyframe> kf = decodeSpoolRecord(*bytes, &session);
  if (kf && (session != session_ || kf->keyframe_id != keyframe_id))
    return Result<msg::Keyframe>::failure("record of keyframe " + std::to_string(keyframe_id) + " changed");
  return kf;
}

void KeyframeSpool::remove(int keyframe_id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(keyframe_id);
    if (it == entries_.end() || it->second.spooled_utime == 0) return;  // unknown, or still being written
    stats_.bytes -= it->second.bytes;
    entries_.erase(it);
    ++stats_.removed;
    stats_.depth = entries_.size();
    stats_.oldest_utime = 0;
    for (const auto& [id, e] : entries_)
      if (e.spooled_utime > 0 && (stats_.oldest_utime == 0 || e.spooled_utime < stats_.oldest_utime))
        stats_.oldest_utime = e.spooled_utime;
  }
  std::error_code ec;
  fs::remove(recordPath(keyframe_id), ec);  // a record left by a crash here is resent: the server re-acks it
}

KeyframeSpoolStats KeyframeSpool::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace rgbdmap
