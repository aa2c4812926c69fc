// Map bundles: export (store -> one file), verification, import (one file -> a new map directory).
#include "rgbdmap/store/map_bundle.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <ctime>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>

#include "bundle_format.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "store_codec.hpp"
#include "store_files.hpp"

namespace rgbdmap::store {
namespace fs = std::filesystem;
namespace {

constexpr const char* kBundleManifestFirstLine = "rgbdmap map bundle";
/// The files of a map directory a bundle carries besides the store: the robots' cameras and mounts, and
/// the octree. Nothing else is ever written from a bundle (no other name, no path).
constexpr std::array<const char*, 3> kCarriedFiles = {"robots.txt", "map.bt", "map.ot"};

bool isCarried(const std::string& name) {
  return std::any_of(kCarriedFiles.begin(), kCarriedFiles.end(), [&](const char* c) { return name == c; });
}

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

msg::Bytes textBytes(const std::string& text) { return msg::Bytes(text.begin(), text.end()); }

msg::Bytes endEntry(int64_t keyframes, int64_t loops) {
  msg::Bytes out;
  ByteWriter w(&out);
  w.i64(keyframes);
  w.i64(loops);
  return out;
}

Status parseManifest(const msg::Bytes& payload, MapBundleInfo* info) {
  std::istringstream in(std::string(payload.begin(), payload.end()));
  std::string line;
  if (!std::getline(in, line) || line != kBundleManifestFirstLine)
    return Status::failure("its manifest is not an rgbdmap map bundle manifest");
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string key, value;
    if (!(fields >> key) || !std::getline(fields >> std::ws, value)) continue;
    if (key == "format_version") info->format_version = std::atoi(value.c_str());
    if (key == "message_schema_version") info->message_schema_version = std::atoi(value.c_str());
    if (key == "created_utc") info->created_utc = value;
    if (key == "source") info->source = value;
  }
  if (info->format_version != kMapBundleFormatVersion)
    return Status::failure("its manifest says format version " + std::to_string(info->format_version));
  if (!msg::isReadableStoredSchema(info->message_schema_version))
    return Status::failure("it holds messages of schema version " +
                           std::to_string(info->message_schema_version) +
                           "; this build decodes schema versions " + msg::readableStoredSchemas());
  return Status::success();
}

struct BundleVisitor {
  /// The decoded keyframe and its record payload as stored.
  std::function<Status(const StoredKeyframe&, const msg::Bytes&)> keyframe =
      [](const StoredKeyframe&, const msg::Bytes&) { return Status::success(); };
  std::function<Status(const StoredLoop&)> loop = [](const StoredLoop&) { return Status::success(); };
  std::function<Status(const std::string&, const std::string&)> file =
      [](const std::string&, const std::string&) { return Status::success(); };
};

void countKeyframe(const StoredKeyframe& k, MapBundleInfo* info, std::set<int64_t>* sessions) {
  ++info->keyframes;
  ++info->keyframes_per_robot[k.keyframe.robot_id];
  sessions->insert(k.session);
}

/// Reads and checks every entry of a bundle, in order, handing each to `visit`.
Result<MapBundleInfo> readBundle(const std::string& path, const BundleVisitor& visit) {
  using R = Result<MapBundleInfo>;
  auto reader = BundleReader::open(path);
  if (!reader) return R::failure(reader.error());
  MapBundleInfo info;
  info.bundle_bytes = (*reader)->size();
  std::set<int64_t> sessions;
  const std::string what = "map bundle '" + path + "': ";
  BundleEntry kind{};
  msg::Bytes payload;
  for (int64_t index = 0;; ++index) {
    if (Status s = (*reader)->next(&kind, &payload); !s) return R::failure(what + s.error());
    if ((index == 0) != (kind == BundleEntry::kManifest))
      return R::failure(what + (index == 0 ? "it does not start with its manifest" : "a second manifest"));
    Status s = Status::success();
    switch (kind) {
      case BundleEntry::kManifest:
        s = parseManifest(payload, &info);
        break;
      case BundleEntry::kKeyframe: {
        Result<StoredKeyframe> k = decodeKeyframePayload(payload.data(), payload.size());
        s = k ? visit.keyframe(*k, payload)
              : Status::failure("keyframe " + std::to_string(info.keyframes) + ": " + k.error());
        if (k) countKeyframe(*k, &info, &sessions);
        break;
      }
      case BundleEntry::kLoop: {
        Result<StoredLoop> l = decodeLoopPayload(payload.data(), payload.size());
        s = l ? visit.loop(*l) : Status::failure("loop " + std::to_string(info.loops) + ": " + l.error());
        ++info.loops;
        break;
      }
      case BundleEntry::kFile: {
        std::string name, bytes;
        s = parseFileEntry(payload, &name, &bytes);
        if (s && !isCarried(name)) s = Status::failure("a file entry named '" + name + "', which no map has");
        if (s && info.files.count(name)) s = Status::failure("the file '" + name + "' twice");
        if (s) s = visit.file(name, bytes);
        if (s) info.files[name] = static_cast<int64_t>(bytes.size());
        break;
      }
      case BundleEntry::kEnd:
        if (payload.size() != 16 || ByteReader(payload.data()).i64() != info.keyframes ||
            ByteReader(payload.data() + 8).i64() != info.loops)
          return R::failure(what + "its end entry does not match the keyframes and loops it holds");
        if (!(*reader)->atEnd()) return R::failure(what + "entries after its end entry");
        info.sessions.assign(sessions.begin(), sessions.end());
        return info;
      default:
        s = Status::failure("an entry of unknown kind " + std::to_string(static_cast<int>(kind)));
    }
    if (!s) return R::failure(what + s.error());
  }
}

Status syncFile(const std::string& path) {
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) return Status::failure(systemError("cannot open", path));
  if (::fsync(fd.get()) != 0) return Status::failure(systemError("cannot fsync", path));
  return Status::success();
}

}  // namespace

Result<MapBundleInfo> exportMapBundle(const std::string& map_dir, const std::string& bundle_path) {
  using R = Result<MapBundleInfo>;
  if (!fs::is_regular_file(fs::path(map_dir) / "MANIFEST"))
    return R::failure("'" + map_dir + "' is not a map directory (it has no MANIFEST)");
  auto store = MapStore::open(map_dir);
  if (!store) return R::failure(store.error());
  const MapStore& s = **store;
  auto writer = BundleWriter::create(bundle_path);
  if (!writer) return R::failure(writer.error());
  std::ostringstream manifest;
  manifest << kBundleManifestFirstLine << "\nformat_version " << kMapBundleFormatVersion
           << "\nmessage_schema_version " << msg::kSchemaVersion << "\ncreated_utc " << utcNow()
           << "\nsource " << fs::absolute(map_dir).lexically_normal().string() << "\nkeyframes "
           << s.keyframes().size() << "\nloops " << s.loops().size() << "\n";
  if (Status st = (*writer)->add(BundleEntry::kManifest, textBytes(manifest.str())); !st)
    return R::failure(st.error());
  for (const StoredKeyframe& k : s.keyframes()) {
    Result<msg::Bytes> payload = s.readKeyframePayload(k.node_id);  // as stored: the copy is exact
    if (!payload) return R::failure(payload.error());
    if (Status st = (*writer)->add(BundleEntry::kKeyframe, *payload); !st) return R::failure(st.error());
  }
  for (size_t i = 0; i < s.loops().size(); ++i) {
    StoredLoop loop = s.loops()[i];
    auto pairs = s.readLoopPairs(i);
    if (!pairs) return R::failure("loop " + std::to_string(i) + ": " + pairs.error());
    loop.inlier_pairs = std::move(*pairs);
    Result<msg::Bytes> payload = encodeLoopPayload(loop);
    if (!payload) return R::failure(payload.error());
    if (Status st = (*writer)->add(BundleEntry::kLoop, *payload); !st) return R::failure(st.error());
  }
  for (const char* name : kCarriedFiles) {
    const fs::path file = fs::path(map_dir) / name;
    if (!fs::is_regular_file(file)) continue;
    Result<std::string> bytes = readTextFile(file.string());
    if (!bytes) return R::failure(bytes.error());
    if (Status st = (*writer)->add(BundleEntry::kFile, fileEntry(name, *bytes)); !st)
      return R::failure(st.error());
  }
  const auto keyframes = static_cast<int64_t>(s.keyframes().size()),
             loops = static_cast<int64_t>(s.loops().size());
  if (Status st = (*writer)->add(BundleEntry::kEnd, endEntry(keyframes, loops)); !st)
    return R::failure(st.error());
  if (Result<int64_t> size = (*writer)->finish(); !size) return R::failure(size.error());
  store->reset();  // the written bundle is read back whole: what it says is what it holds
  return readMapBundleInfo(bundle_path);
}

Result<MapBundleInfo> readMapBundleInfo(const std::string& bundle_path) {
  return readBundle(bundle_path, {});
}

Result<MapBundleInfo> importMapBundle(const std::string& bundle_path, const std::string& map_dir) {
  using R = Result<MapBundleInfo>;
  std::error_code ec;
  const fs::path target = fs::path(map_dir).lexically_normal();
  if (fs::exists(target, ec) && (!fs::is_directory(target, ec) || !fs::is_empty(target, ec)))
    return R::failure("'" + map_dir +
                      "' exists and is not an empty folder: a bundle is imported into a new one");
  const fs::path tmp = target.string() + ".import-" + std::to_string(::getpid());
  fs::remove_all(tmp, ec);
  struct Cleanup {
    fs::path dir;
    bool keep = false;
    ~Cleanup() {
      std::error_code e;
      if (!keep) fs::remove_all(dir, e);
    }
  } cleanup{tmp};
  MapStoreOptions options;
  options.sync = false;  // the logs are synced once, below, before the folder is renamed into place
  auto store = MapStore::open(tmp.string(), options);
  if (!store) return R::failure(store.error());
  BundleVisitor visit;
  visit.keyframe = [&](const StoredKeyframe&, const msg::Bytes& payload) {
    return (*store)->appendKeyframePayload(payload);
  };
  visit.loop = [&](const StoredLoop& l) { return (*store)->appendLoop(l); };
  visit.file = [&](const std::string& name, const std::string& bytes) {
    return writeFileAtomic((tmp / name).string(), bytes);
  };
  R info = readBundle(bundle_path, visit);
  if (!info) return info;
  store->reset();
  for (const char* log : {"keyframes.log", "loops.log"})
    if (fs::exists(tmp / log))
      if (Status s = syncFile((tmp / log).string()); !s) return R::failure(s.error());
  if (Status s = syncFolder(tmp.string()); !s) return R::failure(s.error());
  if (fs::exists(target, ec)) fs::remove(target, ec);  // an empty folder
  if (::rename(tmp.c_str(), target.c_str()) != 0)
    return R::failure(systemError("cannot rename the imported map to '" + map_dir + "'", tmp.string()));
  cleanup.keep = true;
  if (Status s = syncFolder(folderOf(target.string())); !s) return R::failure(s.error());
  return info;
}

}  // namespace rgbdmap::store
