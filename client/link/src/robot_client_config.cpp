// robot.*, transport.*, link.* keys of the robot program's configuration.
#include "rgbdmap/link/robot_client_config.hpp"

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {
namespace {

void readReliable(ConfigReader& reader, transport::ReliableSenderOptions* r) {
  int max_pending = static_cast<int>(r->max_pending);
  int initial_ms = static_cast<int>(r->initial_backoff.count());
  int max_ms = static_cast<int>(r->max_backoff.count());
  reader.read("link.reliable.max_pending", &max_pending, 1, 100000);
  reader.read("link.reliable.initial_backoff_ms", &initial_ms, 1, 600000);
  reader.read("link.reliable.max_backoff_ms", &max_ms, 1, 600000);
  reader.read("link.reliable.backoff_factor", &r->backoff_factor, 1.0, 10.0);
  reader.read("link.reliable.jitter", &r->jitter, 0.0, 0.9);
  reader.read("link.reliable.max_attempts", &r->max_attempts, 1, 100000);
  if (max_ms < initial_ms)
    reader.addError(reader.source() + ": link.reliable.max_backoff_ms must be >= initial_backoff_ms");
  r->max_pending = static_cast<size_t>(max_pending);
  r->initial_backoff = std::chrono::milliseconds(initial_ms);
  r->max_backoff = std::chrono::milliseconds(max_ms);
}

void readCodec(ConfigReader& reader, ImageCodecOptions* c) {
  std::string color = toString(c->color), depth = toString(c->depth_filter);
  reader.read("link.codec.color", &color, {"jpeg", "lossless", "none"});
  reader.read("link.codec.depth_filter", &depth, {"rank-med", "row-delta", "none"});
  reader.read("link.codec.jpeg_quality", &c->jpeg_quality, 1, 100);
  reader.read("link.codec.min_jpeg_quality", &c->min_jpeg_quality, 1, 100);
  int max_bytes = static_cast<int>(c->max_keyframe_bytes);
  reader.read("link.codec.max_keyframe_bytes", &max_bytes, 0, msg::kMaxEnvelopeBytes);
  c->max_keyframe_bytes = static_cast<size_t>(max_bytes);
  reader.read("link.codec.zstd_level", &c->zstd_level, 1, 19);
  c->color = color == "lossless" ? ColorCodec::kLossless
             : color == "none"   ? ColorCodec::kNone
                                 : ColorCodec::kJpeg;
  c->depth_filter = depth == "row-delta" ? DepthFilter::kRowDelta
                    : depth == "none"    ? DepthFilter::kNone
                                         : DepthFilter::kRankMed;
}

}  // namespace

void readRobotClientConfig(ConfigReader& reader, RobotClientConfig* config) {
  reader.read("robot.id", &config->robot_id);
  reader.read("robot.key_file", &config->key_file);
  reader.read("transport.url", &config->transport_url);
  RobotLinkOptions& link = config->link;
  reader.read("link.heartbeat_period_s", &link.heartbeat_period_s, 0.01, 3600.0);
  reader.read("link.hello_period_s", &link.hello_period_s, 0.01, 3600.0);
  reader.read("link.send_timeout_s", &link.send_timeout_s, 0.0, 3600.0);
  reader.read("link.final_wait_s", &config->final_wait_s, 0.0, 3600.0);
  readReliable(reader, &link.reliable);
  readCodec(reader, &link.codec);
}

Result<msg::Bytes> readKeyFile(const std::string& path, const std::string& base_dir) {
  std::filesystem::path p(path);
  if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
  std::ifstream in(p);
  if (!in) return Result<msg::Bytes>::failure("cannot read key file " + p.string());
  std::string hex, line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t") != std::string::npos && line[line.find_first_not_of(" \t")] == '#')
      continue;
    for (const char ch : line)
      if (!std::isspace(static_cast<unsigned char>(ch))) hex += ch;
  }
  Result<msg::Bytes> key = msg::parseHexKey(hex);
  if (!key) return Result<msg::Bytes>::failure("key file " + p.string() + ": " + key.error());
  return key;
}

}  // namespace rgbdmap
