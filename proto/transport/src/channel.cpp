// Channel-name rules shared by the adapters: late-joiner channels, DDS topic names, subscription matching.
#include <algorithm>
#include <cctype>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport {
namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

bool isLatestForLateJoiners(const std::string& channel, const TransportOptions& options) {
  // The channels proto/README.md marks "latest for late joiners" (one list, matched by suffix).
  for (const char* suffix : {"/map", "/slice", "/status", "/pose_corrections", "/hello", "/loops"})
    if (endsWith(channel, suffix)) return true;
  const auto& extra = options.latest_for_late_joiners_channels;
  return std::find(extra.begin(), extra.end(), channel) != extra.end();
}

std::string ddsTopicName(const std::string& channel) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  out.reserve(channel.size() + 8);
  for (size_t i = 0; i < channel.size(); ++i) {
    const auto c = static_cast<unsigned char>(channel[i]);
    const bool digit = std::isdigit(c) != 0;
    if ((std::isalpha(c) != 0 && c < 128) || (digit && i > 0)) {
      out.push_back(static_cast<char>(c));
    } else if (c == '/') {
      out += "__";
    } else {
      out += "_x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 0xF]);
    }
  }
  return out;
}

bool channelFromDdsTopic(const std::string& topic, std::string* channel) {
  std::string out;
  for (size_t i = 0; i < topic.size(); ++i) {
    const auto c = static_cast<unsigned char>(topic[i]);
    if (c != '_') {
      if (std::isalnum(c) == 0 || c >= 128) return false;
      out.push_back(static_cast<char>(c));
    } else if (i + 1 < topic.size() && topic[i + 1] == '_') {
      out.push_back('/');
      ++i;
    } else if (i + 3 < topic.size() && topic[i + 1] == 'x' &&
               std::isxdigit(static_cast<unsigned char>(topic[i + 2])) &&
               std::isxdigit(static_cast<unsigned char>(topic[i + 3]))) {
      out.push_back(static_cast<char>(std::stoi(topic.substr(i + 2, 2), nullptr, 16)));
      i += 3;
    } else {
      return false;
    }
  }
  if (ddsTopicName(out) != topic) return false;  // one name per channel: anything else is not ours
  *channel = std::move(out);
  return true;
}

bool channelMatches(const std::string& pattern, const std::string& channel) {
  if (!pattern.empty() && pattern.back() == '*') {
    return channel.compare(0, pattern.size() - 1, pattern, 0, pattern.size() - 1) == 0;
  }
  return pattern == channel;
}

}  // namespace rgbdmap::transport
