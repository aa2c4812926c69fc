#pragma once
// The rgbdmap subcommands; each takes the arguments after its name and returns the exit code.
#include <string>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap::cmd {
int synth(int argc, char** argv);
int odometry(int argc, char** argv);
int convert(int argc, char** argv);
int eval(int argc, char** argv);
int run(int argc, char** argv);
int viewMap(int argc, char** argv);
int keys(int argc, char** argv);
int map(int argc, char** argv);
/// rgbdmap map merge (cmd_map_merge.cpp): the exit code.
int mapMerge(const std::string& a, const std::string& b, const std::string& out);

/// `convert`'s work (also `run --source`): the first `frames` (0: all) of `url` into the TUM folder `out`
/// with the configuration of `args`; the exit code (2 with `usage` on configuration errors).
int convertSource(cli::Args& args, const SourceUrl& url, const std::string& out, long long frames,
                  const char* usage);
}  // namespace rgbdmap::cmd
