#include "rgbdmap/cli/source_setup.hpp"

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/source/seven_scenes.hpp"

namespace rgbdmap::app {

std::optional<SourceUrl> sourceUrlArgument(cli::Args& args, std::vector<std::string>* errors, bool required) {
  const auto dataset = args.get("dataset");
  const auto source = args.get("source");
  if (dataset && source) {
    errors->push_back("--dataset DIR and --source URL are one choice (--dataset DIR = --source tum:DIR)");
    return std::nullopt;
  }
  if (!dataset && !source) {
    if (required) errors->push_back("--source URL (or --dataset DIR) is required");
    return std::nullopt;
  }
  if (dataset) {
    if (dataset->empty()) errors->push_back("--dataset needs a folder");
    SourceUrl url;
    url.scheme = isSevenScenesFolder(*dataset) ? "7scenes" : "tum";  // a 7-Scenes folder has no rgb.txt
    url.path = *dataset;
    return url;
  }
  auto url = SourceUrl::parse(*source);
  if (!url) {
    errors->push_back("--source: " + url.error());
    return std::nullopt;
  }
  return *url;
}

namespace {

SourceOptions sourceOptions(const OdometrySetup& setup, SourceRange range) {
  SourceOptions o;
  o.max_time_diff = setup.dataset.max_time_diff;
  o.depth_scale = setup.dataset.depth_scale;
  o.expected_width = setup.dataset.expected_width;
  o.expected_height = setup.dataset.expected_height;
  o.first_frame = range.first;
  o.end_frame = range.end;
  return o;
}

}  // namespace

Result<OpenedSource> openSource(cli::Args& args, const SourceUrl& url, SourceRange range,
                                std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more) {
  using R = Result<OpenedSource>;
  OpenedSource out;
  if (url.scheme == "tum") {  // the folder's camera.yaml and the dataset: section decide how to read it
    out.setup = loadOdometrySetup(args, url.path, errors, read_more);
    if (!errors->empty()) return R::failure("");
    auto source = openFrameSource(url, sourceOptions(out.setup, range));
    if (!source) return R::failure(source.error());
    out.source = std::move(*source);
    return out;
  }
  // A bag or a device: its camera comes from the source, so it is opened first (default pairing tolerance
  // unless the URL sets max_dt; the configuration's dataset: section is for folders).
  SourceOptions options;
  options.first_frame = range.first;
  options.end_frame = range.end;
  auto source = openFrameSource(url, options);
  if (!source) return R::failure(source.error());
  out.source = std::move(*source);
  const std::optional<CameraIntrinsics> camera = out.source->camera();
  out.setup = loadOdometrySetup(args, camera, out.source->describe(), errors, read_more);
  if (camera) out.setup.camera.depth_scale = camera->depth_scale;  // the frames' units, not a choice
  if (!camera)
    log::warn(out.source->describe(), ": no camera model in the source; using ", out.setup.camera_source);
  if (!errors->empty()) return R::failure("");
  return out;
}

void addConfigErrors(cli::Args& args, const std::optional<SourceUrl>& url, std::vector<std::string>* errors,
                     const std::function<void(ConfigReader&)>& read_more) {
  loadOdometrySetup(args, url && url->scheme == "tum" ? url->path : std::string(), errors, read_more);
}

const char* sourceOptionsHelp() { return sourceUrlHelp(); }

}  // namespace rgbdmap::app
