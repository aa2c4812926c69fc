// rgbdmap map merge A B OUT: two maps of the same place joined offline. OUT starts as an exact copy of A
// (through a bundle), then B's keyframes are sent, session by session, to a mapping server on OUT in this
// process, as robots coming back would send them: its loop closure joins them to A's map, or they stay a map
// of their own and the maps do not overlap. One keyframe at a time, each waiting for its correction (as
// `rgbdmap run` does), so the result does not depend on the machine's load.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "commands.hpp"
#include "local_deployment.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/store/map_bundle.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap::cmd {
namespace {

namespace fs = std::filesystem;

/// B's keyframes per robot, each robot's sessions in the order they were stored.
struct SourceMap {
  std::vector<std::string> robots;
  std::map<std::string, std::vector<std::vector<int64_t>>> sessions;  ///< robot -> sessions -> node ids
  size_t keyframes = 0;
};

SourceMap collect(const MapStore& b) {
  SourceMap m;
  std::map<std::pair<std::string, int64_t>, size_t> session_index;
  for (const StoredKeyframe& k : b.keyframes()) {
    const std::string& robot = k.keyframe.robot_id;
    if (!m.sessions.count(robot)) m.robots.push_back(robot);
    auto& sessions = m.sessions[robot];
    auto [it, added] = session_index.emplace(std::make_pair(robot, k.session), sessions.size());
    if (added) sessions.emplace_back();
    sessions[it->second].push_back(k.node_id);
    ++m.keyframes;
  }
  return m;
}

/// Sends robot `r`'s sessions of B through its link, one keyframe at a time; ids and segments continue
/// across sessions, and each session's first keyframe starts a new chain.
Status sendRobot(const MapStore& b, const std::vector<std::vector<int64_t>>& sessions, RobotLink& link,
                 size_t* sent) {
  int id_offset = 0, segment_offset = 0;
  for (const std::vector<int64_t>& nodes : sessions) {
    int max_id = 0, max_segment = 0;
    std::set<int> sent_here;
    for (int64_t node : nodes) {
      Result<StoredKeyframe> read = b.readKeyframe(node);
      if (!read) return Status::failure(read.error());
      msg::Keyframe k = std::move(read->keyframe);
      max_id = std::max(max_id, k.keyframe_id);
      max_segment = std::max(max_segment, k.segment_id);
      const bool chained = k.previous_keyframe_id >= 0 && sent_here.count(k.previous_keyframe_id) > 0;
      sent_here.insert(k.keyframe_id);
      k.keyframe_id += id_offset;
      k.previous_keyframe_id = chained ? k.previous_keyframe_id + id_offset : -1;
      k.segment_id += segment_offset;
      const int id = k.keyframe_id, segment = k.segment_id;
      if (Status s = link.sendKeyframeMessage(std::move(k)); !s) return s;
      link.setTrackingState(id, segment, TrackingState::kTracking);
      if (!link.waitForCorrection(id, 60.0))
        return Status::failure("no correction for keyframe " + std::to_string(id) + " within 60 s");
      ++*sent;
    }
    id_offset += max_id + 1;
    segment_offset += max_segment + 1;
  }
  return Status::success();
}

/// Which of the server's maps hold A's keyframes (a_nodes) and which B's.
std::pair<std::set<int>, std::set<int>> mapsOf(const std::vector<ServerKeyframe>& keyframes,
                                               const std::set<int64_t>& a_nodes) {
  std::set<int> a, b;
  for (const ServerKeyframe& k : keyframes) (a_nodes.count(k.node_id) ? a : b).insert(k.map_id);
  return {a, b};
}

Result<std::set<int64_t>> nodesOf(const std::string& dir) {
  auto store = MapStore::open(dir);
  if (!store) return Result<std::set<int64_t>>::failure(store.error());
  std::set<int64_t> nodes;
  for (const StoredKeyframe& k : (*store)->keyframes()) nodes.insert(k.node_id);
  return nodes;
}

bool isMapDir(const std::string& path) { return fs::is_regular_file(fs::path(path) / "MANIFEST"); }

/// OUT's start: an exact copy of A (a map directory, through a bundle; or a bundle, imported).
Status copyInto(const std::string& a, const fs::path& tmp) {
  if (fs::is_regular_file(a)) {
    auto imported = store::importMapBundle(a, tmp.string());
    return imported ? Status::success() : Status::failure(imported.error());
  }
  if (!isMapDir(a)) return Status::failure("'" + a + "' is neither a map directory nor a map bundle");
  const fs::path bundle = tmp.string() + ".a.rmb";
  auto exported = store::exportMapBundle(a, bundle.string());
  if (!exported) return Status::failure(exported.error());
  auto imported = store::importMapBundle(bundle.string(), tmp.string());
  std::error_code ec;
  fs::remove(bundle, ec);
  return imported ? Status::success() : Status::failure(imported.error());
}

/// B as a map directory to read: itself, or a bundle imported into `scratch`.
Result<std::string> sourceDir(const std::string& b, const fs::path& scratch) {
  if (fs::is_regular_file(b)) {
    auto imported = store::importMapBundle(b, scratch.string());
    if (!imported) return Result<std::string>::failure(imported.error());
    return scratch.string();
  }
  if (!isMapDir(b))
    return Result<std::string>::failure("'" + b + "' is neither a map directory nor a map bundle");
  return b;
}

Status mergeInto(const std::string& a, const std::string& b_arg, const fs::path& tmp,
                 const fs::path& scratch) {
  if (Status s = copyInto(a, tmp); !s) return s;
  auto b_dir = sourceDir(b_arg, scratch);
  if (!b_dir) return Status::failure(b_dir.error());
  const std::string& b = *b_dir;
  auto a_nodes = nodesOf(tmp.string());
  if (!a_nodes) return Status::failure(a_nodes.error());
  auto source = MapStore::open(b);
  if (!source) return Status::failure(source.error());
  const SourceMap m = collect(**source);
  if (m.keyframes == 0) return Status::failure("'" + b + "' holds no keyframe");
  RobotRegistry cameras;
  if (Status s = cameras.load(b); !s) return Status::failure("'" + b + "': " + s.error());
  std::vector<LocalRobotSpec> specs;
  for (const std::string& robot : m.robots) {
    auto camera = cameras.camera(robot);
    if (!camera) return Status::failure("'" + b + "/robots.txt' has no camera for robot " + robot);
    auto key = msg::newKey();
    if (!key) return Status::failure(key.error());
    specs.push_back({robot, *key, *camera, cameras.mount(robot)});
  }
  MapServerConfig config;
  config.map_dir = tmp.string();
  auto deployment = LocalDeployment::start("memq://", config, specs);
  if (!deployment) return Status::failure(deployment.error());
  size_t sent = 0;
  for (size_t i = 0; i < specs.size(); ++i)
    if (Status s = sendRobot(**source, m.sessions.at(specs[i].id), (*deployment)->link(i), &sent); !s)
      return Status::failure("sending " + specs[i].id + "'s keyframes of '" + b + "': " + s.error());
  (*deployment)->settle(120.0, 20.0);
  const auto [maps_a, maps_b] = mapsOf((*deployment)->server().keyframes(), *a_nodes);
  bool joined = false;
  for (int id : maps_b) joined = joined || maps_a.count(id) > 0;
  log::info("merge: ", sent, " keyframes of '", b, "' sent; A's keyframes in ", maps_a.size(),
            " map(s), B's in ", maps_b.size(), joined ? ", joined" : ", not joined");
  if (!joined)
    return Status::failure("the maps do not overlap: no loop closure joined a keyframe of '" + b +
                           "' to the map of '" + a + "'");
  if (Status s = (*deployment)->server().writeMapOutputs(tmp.string()); !s) return s;
  (*deployment)->stop();
  return Status::success();
}

}  // namespace

int mapMerge(const std::string& a, const std::string& b, const std::string& out) {
  std::error_code ec;
  const fs::path target = fs::path(out).lexically_normal();
  if (fs::exists(target, ec) && (!fs::is_directory(target, ec) || !fs::is_empty(target, ec))) {
    std::fprintf(stderr, "rgbdmap map merge: '%s' exists and is not an empty folder\n", out.c_str());
    return 1;
  }
  const fs::path tmp = target.string() + ".merge-" + std::to_string(::getpid());
  fs::remove_all(tmp, ec);
  const fs::path scratch = target.string() + ".merge-b-" + std::to_string(::getpid());
  fs::remove_all(scratch, ec);
  const Status merged = mergeInto(a, b, tmp, scratch);
  fs::remove_all(scratch, ec);
  if (merged && fs::exists(target, ec)) fs::remove(target, ec);  // an empty folder
  if (!merged || ::rename(tmp.c_str(), target.c_str()) != 0) {
    std::fprintf(stderr, "rgbdmap map merge: %s\n",
                 merged ? ("cannot rename the merged map to '" + out + "'").c_str() : merged.error().c_str());
    fs::remove_all(tmp, ec);
    return 1;
  }
  if (Status s = syncFolder(folderOf(target.string())); !s) log::warn("merge: ", s.error());
  std::printf("merged %s and %s into %s\n", a.c_str(), b.c_str(), out.c_str());
  return 0;
}

}  // namespace rgbdmap::cmd
