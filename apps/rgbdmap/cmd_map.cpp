// rgbdmap map: map bundles (server/store/README.md, "Map bundles"): export a map directory as one file,
// verify and describe a bundle, import one into a new map directory.
#include <cstdio>
#include <cstring>
#include <string>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/store/map_bundle.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kMapUsage =
    "usage: rgbdmap map export MAP_DIR FILE | info FILE | import FILE MAP_DIR | merge A B OUT [--help]\n"
    "Map bundles: one versioned, checksummed file (SHA-256 over the file, CRC-32 per entry) with\n"
    "everything a server needs to serve a map: its keyframes (features and images), loop edges, the\n"
    "robots' cameras and mounts (robots.txt) and the octree (map.bt, map.ot).\n"
    "  export  writes MAP_DIR (a server's map directory, not while a server has it open) to FILE\n"
    "          (a temporary file, synced and renamed), then reads it back and prints what it holds\n"
    "  info    verifies FILE entirely and prints what it holds, as `key value` lines\n"
    "  import  creates MAP_DIR (missing or empty) from FILE; a damaged or foreign file is refused and\n"
    "          nothing is written. Serve it with rgbdmap-server (server.map_dir: MAP_DIR)\n"
    "  merge   joins the maps A and B (map directories or bundles) into the map directory OUT (missing\n"
    "          or empty): OUT starts as a copy of A, then B's keyframes go, session by session, to a\n"
    "          mapping server on OUT in this process, whose loop closure joins them to A's map; fails\n"
    "          (nothing written) when no loop closure joins them: the maps do not overlap\n"
    "exit status: 0 success, 1 the map or the file could not be read or written (the reason is printed),\n"
    "2 usage error\n";

void printInfo(const char* path, const store::MapBundleInfo& info) {
  std::printf("file %s\nbundle_bytes %lld\nformat_version %d\nmessage_schema_version %d\ncreated_utc %s\n",
              path, static_cast<long long>(info.bundle_bytes), info.format_version,
              info.message_schema_version, info.created_utc.c_str());
  std::printf("source %s\nkeyframes %lld\nloops %lld\nsessions %zu\n", info.source.c_str(),
              static_cast<long long>(info.keyframes), static_cast<long long>(info.loops),
              info.sessions.size());
  for (const auto& [robot, count] : info.keyframes_per_robot)
    std::printf("robot %s keyframes %lld\n", robot.c_str(), static_cast<long long>(count));
  for (const auto& [name, bytes] : info.files)
    std::printf("carried %s %lld\n", name.c_str(), static_cast<long long>(bytes));
}

}  // namespace

int map(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::fputs(kMapUsage, stdout);
    return 0;
  }
  args.checkAllowed({"help"});
  const auto& pos = args.positional();
  const std::string verb = pos.empty() ? "" : pos[0];
  const size_t want = verb == "info"                           ? 2
                      : (verb == "export" || verb == "import") ? 3
                      : verb == "merge"                        ? 4
                                                               : 0;
  if (want == 0)
    args.addError(verb.empty() ? "expected export, info, import or merge"
                               : "unknown map command '" + verb + "'");
  else if (pos.size() != want)
    args.addError("map " + verb + " takes " + std::to_string(want - 1) + " argument(s), got " +
                  std::to_string(pos.size() - 1));
  if (!args.errors().empty()) return cli::usageError(args.errors(), kMapUsage);
  if (verb == "merge") return mapMerge(pos[1], pos[2], pos[3]);
  Result<store::MapBundleInfo> info = verb == "export"   ? store::exportMapBundle(pos[1], pos[2])
                                      : verb == "import" ? store::importMapBundle(pos[1], pos[2])
                                                         : store::readMapBundleInfo(pos[1]);
  if (!info) {
    std::fprintf(stderr, "rgbdmap map %s: %s\n", verb.c_str(), info.error().c_str());
    return 1;
  }
  printInfo((verb == "export" ? pos[2] : pos[1]).c_str(), *info);
  if (verb == "import") std::printf("imported_into %s\n", pos[2].c_str());
  return 0;
}

}  // namespace rgbdmap::cmd
