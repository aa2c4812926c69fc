#pragma once
// Where a command's frames come from: `--source URL` or `--dataset DIR` (= tum:DIR, or 7scenes:DIR for a
// 7-Scenes folder), opened together with the configuration, so that the camera follows one order, lowest
// priority first: built-in defaults, the source's own camera (a folder's camera.yaml, a bag's camera_info,
// the device), the camera: section of --config, the command-line overrides.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap::app {

/// --source URL or --dataset DIR as a SourceUrl; nullopt with the reason in *errors when neither (if
/// `required`), both, or a malformed URL is given.
std::optional<SourceUrl> sourceUrlArgument(cli::Args& args, std::vector<std::string>* errors, bool required);

struct OpenedSource {
  std::unique_ptr<FrameSource> source;
  OdometrySetup setup;
};

struct SourceRange {
  size_t first = 0;
  long long end = -1;  ///< exclusive; -1 = until the source ends
};

/// Reads the configuration and opens the source. Configuration problems go to *errors (the caller exits
/// with 2 when there are any; then the result is a failure with an empty reason); a source that cannot be
/// opened is a failure naming what was tried (exit 1).
Result<OpenedSource> openSource(cli::Args& args, const SourceUrl& url, SourceRange range,
                                std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more = nullptr);

/// When the command line already has errors: adds the configuration's own (--config, --intrinsics, a
/// folder's camera.yaml) so that every error is reported at once; opens nothing.
void addConfigErrors(cli::Args& args, const std::optional<SourceUrl>& url, std::vector<std::string>* errors,
                     const std::function<void(ConfigReader&)>& read_more = nullptr);

/// --source in the option list and usage text of every dataset command.
const char* sourceOptionsHelp();

}  // namespace rgbdmap::app
