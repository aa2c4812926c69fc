// rgbdmap: one binary, several subcommands (synth, odometry, convert, eval, run, view-map, keys, map).
#include <cstdio>
#include <cstring>
#include <exception>

#include "commands.hpp"

namespace {
const char* kUsage =
    "usage: rgbdmap <command> [options]\n"
    "commands:\n"
    "  run       the main job: odometry on a dataset (synthesised when none is given), evaluated, with a "
    "report\n"
    "  synth     write a synthetic RGB-D sequence in TUM layout with exact ground truth\n"
    "  odometry  run the client's visual odometry on a TUM-layout dataset, a ROS bag or a camera\n"
    "  convert   write any frame source (ROS bag, camera) as a TUM-layout folder\n"
    "  eval      ATE and RPE of an estimated trajectory against ground truth\n"
    "  view-map  statistics of an octree map file (.bt or .ot)\n"
    "  keys      keys new ROBOT...: a key per robot and the server's keys file\n"
    "  map       map bundles: export MAP_DIR FILE, info FILE, import FILE MAP_DIR\n"
    "run `rgbdmap <command> --help` for its options.\n";
}

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  const char* name = argv[1];
  try {
    if (!std::strcmp(name, "synth")) return rgbdmap::cmd::synth(argc - 2, argv + 2);
    if (!std::strcmp(name, "odometry")) return rgbdmap::cmd::odometry(argc - 2, argv + 2);
    if (!std::strcmp(name, "convert")) return rgbdmap::cmd::convert(argc - 2, argv + 2);
    if (!std::strcmp(name, "eval")) return rgbdmap::cmd::eval(argc - 2, argv + 2);
    if (!std::strcmp(name, "run")) return rgbdmap::cmd::run(argc - 2, argv + 2);
    if (!std::strcmp(name, "view-map")) return rgbdmap::cmd::viewMap(argc - 2, argv + 2);
    if (!std::strcmp(name, "keys")) return rgbdmap::cmd::keys(argc - 2, argv + 2);
    if (!std::strcmp(name, "map")) return rgbdmap::cmd::map(argc - 2, argv + 2);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rgbdmap %s: unexpected error: %s\n", name, e.what());
    return 1;
  }
  std::fprintf(stderr, "rgbdmap: unknown command '%s'\n%s", name, kUsage);
  return 2;
}
