// rgbdmap view-map: statistics of an OctoMap file (.bt binary or .ot full format).
#include <cstdio>
#include <string>

#include <octomap/OcTree.h>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/map/map_io.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kViewMapUsage =
    "usage: rgbdmap view-map FILE.bt|FILE.ot [--help]\n"
    "Prints an octree map's statistics as `key value` lines: resolution, file and memory size, bounds,\n"
    "leaf counts and volumes. The file is checked before it is parsed (corrupt files are reported).\n"
    "exit status: 0 success, 1 unreadable or corrupt file, 2 usage error\n";

}  // namespace

int viewMap(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::fputs(kViewMapUsage, stdout);
    return 0;
  }
  args.checkAllowed({"help"});
  if (args.positional().size() != 1) args.addError("expected exactly one map file");
  if (!args.errors().empty()) return cli::usageError(args.errors(), kViewMapUsage);
  const std::string path = args.positional()[0];
  const auto tree = readMapFile(path);
  if (!tree) {
    std::fprintf(stderr, "rgbdmap view-map: %s\n", tree.error().c_str());
    return 1;
  }
  const TreeSummary s = summarizeTree(**tree);
  std::printf("file %s\n", path.c_str());
  std::printf("resolution_m %g\n", s.resolution_m);
  std::printf("nodes %zu\nleaf_nodes %zu\noccupied_leaves %zu\nfree_leaves %zu\n", s.nodes, s.leaf_nodes,
              s.occupied_leaves, s.free_leaves);
  std::printf("memory_bytes %zu\nbinary_bytes %zu\n", s.memory_bytes, s.binary_bytes);
  std::printf("bounds_min_m %.3f %.3f %.3f\nbounds_max_m %.3f %.3f %.3f\n", s.min[0], s.min[1], s.min[2],
              s.max[0], s.max[1], s.max[2]);
  std::printf("occupied_volume_m3 %.4f\nfree_volume_m3 %.4f\n", s.occupied_volume_m3, s.free_volume_m3);
  return 0;
}

}  // namespace rgbdmap::cmd
