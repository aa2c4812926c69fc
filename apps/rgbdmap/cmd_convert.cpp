// rgbdmap convert: any frame source (TUM folder, ROS 1 bag, live camera) written as a TUM-layout folder.
#include <cstdio>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/progress.hpp"
#include "rgbdmap/cli/source_setup.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/source/frame_recorder.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kConvertUsage =
    "usage: rgbdmap convert --source URL --out DIR [--frames N] [options]\n"
    "Writes the frames of URL into DIR in TUM layout (rgb/, depth/ 16-bit PNG, rgb.txt, depth.txt,\n"
    "camera.yaml with the camera in effect and the depth units, groundtruth.txt when the source has one),\n"
    "e.g. a TUM benchmark .bag to a folder that --dataset DIR reads without the bag libraries.\n"
    "  --out DIR               output folder (created; same-named files are overwritten)\n"
    "  --frames N              only the first N frames (needed to end a live source)\n";

}  // namespace

int convert(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::printf("%s%s%s", kConvertUsage, app::sourceOptionsHelp(), app::datasetOptionsHelp());
    return 0;
  }
  auto allowed = app::datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "source", "out", "frames"});
  args.checkAllowed(allowed);
  std::vector<std::string> errors;
  const auto url = app::sourceUrlArgument(args, &errors, true);
  const auto out = args.get("out");
  if (!out) errors.push_back("--out is required");
  const long long frames = args.getInt("frames").value_or(0);
  if (frames < 0) errors.push_back("--frames must be >= 0");
  cli::applyLogLevel(args, &errors);
  if (!errors.empty() || !args.errors().empty()) app::addConfigErrors(args, url, &errors);
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  if (!errors.empty() || !url) return cli::usageError(errors, kConvertUsage);
  return convertSource(args, *url, *out, frames, kConvertUsage);
}

int convertSource(cli::Args& args, const SourceUrl& url, const std::string& out, long long frames,
                  const char* usage) {
  std::vector<std::string> errors;
  auto opened = app::openSource(args, url, {0, frames > 0 ? frames : -1}, &errors);
  if (!errors.empty()) return cli::usageError(errors, usage);
  if (!opened) return log::error(opened.error()), 1;
  auto recorder = TumRecorder::create(out, opened->setup.camera);
  if (!recorder) return log::error(recorder.error()), 1;
  log::info("converting ", opened->source->describe(), " into ", out);
  const size_t total = opened->source->sizeHint();
  RecordingSource source(std::move(opened->source), std::move(*recorder));
  app::Progress progress("convert", total);
  size_t unreadable = 0;
  std::string failure;
  for (size_t done = 1;; ++done) {
    const FrameRead read = source.next();
    if (read.kind == FrameRead::Kind::kEnd) break;
    if (read.kind == FrameRead::Kind::kFailed) {
      failure = read.error;
      break;
    }
    if (read.kind == FrameRead::Kind::kUnreadable) {
      ++unreadable;
      log::warn("skipping frame ", read.index, ": ", read.error);
    }
    progress.update(done);
  }
  progress.finish();
  if (Status s = source.finish(); !s) return log::error(s.error()), 1;
  std::fprintf(stderr, "wrote %zu frames to %s (unreadable %zu, dropped %zu)\n", source.recorded(),
               out.c_str(), unreadable, source.droppedFrames());
  if (!failure.empty()) return log::error(failure), 1;
  if (source.recorded() == 0) return log::error(source.describe(), ": no frame could be read"), 1;
  return 0;
}

}  // namespace rgbdmap::cmd
