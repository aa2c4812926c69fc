// FaultInjectingTransport: seeded whole-message loss on publish and on receive (tests and benchmarks only).
#include "fault_transport.hpp"

#include <cstdlib>
#include <vector>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::transport {
namespace {

bool parseProbability(const std::string& text, double* out) {
  char* end = nullptr;
  const double p = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(p >= 0.0 && p < 1.0)) return false;
  *out = p;
  return true;
}

bool parseSeed(const std::string& text, uint64_t* out) {
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || text[0] == '-') return false;
  *out = v;
  return true;
}

}  // namespace

std::string parseFaultOptions(std::string* url, FaultOptions* out) {
  *out = FaultOptions{};
  out->seed = 1;
  const auto q = url->find('?');
  if (q == std::string::npos) return "";
  std::vector<std::string> kept;
  std::string error;
  size_t pos = q + 1;
  while (pos <= url->size()) {
    const size_t end = std::min(url->find('&', pos), url->size());
    const std::string item = url->substr(pos, end - pos);
    pos = end + 1;
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq), value = eq == std::string::npos ? "" : item.substr(eq + 1);
    bool ok = true;
    if (key == "drop") {
      ok = parseProbability(value, &out->drop_publish);
    } else if (key == "drop_rx") {
      ok = parseProbability(value, &out->drop_receive);
    } else if (key == "drop_seed") {
      ok = parseSeed(value, &out->seed);
    } else {
      if (!item.empty()) kept.push_back(item);
      continue;
    }
    if (!ok && error.empty())
      error = "bad fault parameter '" + item + "' (drop and drop_rx in [0, 1), drop_seed >= 0)";
  }
  std::string rest = url->substr(0, q);
  for (size_t i = 0; i < kept.size(); ++i) rest += (i == 0 ? "?" : "&") + kept[i];
  *url = rest;
  return error;
}

FaultInjectingTransport::FaultInjectingTransport(std::unique_ptr<Transport> inner,
                                                 const FaultOptions& options)
    : inner_(std::move(inner)), options_(options), rng_(options.seed) {
  log::warn("FAULT INJECTION ON: dropping ", options_.drop_publish * 100.0, " % of published and ",
            options_.drop_receive * 100.0, " % of received messages on purpose (seed ", options_.seed,
            "); for tests and benchmarks only");
}

bool FaultInjectingTransport::drop(double probability) {
  if (probability <= 0.0) return false;
  std::lock_guard<std::mutex> lock(rng_mutex_);
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < probability;
}

Status FaultInjectingTransport::publish(const std::string& channel, const uint8_t* data, size_t size) {
  if (drop(options_.drop_publish)) {
    dropped_published_.fetch_add(1, std::memory_order_relaxed);
    return Status::success();  // lost on the way: the sender cannot tell
  }
  return inner_->publish(channel, data, size);
}

Status FaultInjectingTransport::subscribe(const std::string& channel, Handler handler) {
  if (options_.drop_receive <= 0.0) return inner_->subscribe(channel, std::move(handler));
  return inner_->subscribe(channel, [this, handler = std::move(handler)](const std::string& name,
                                                                         const uint8_t* data, size_t size) {
    if (drop(options_.drop_receive)) {
      dropped_received_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    handler(name, data, size);
  });
}

TransportStats FaultInjectingTransport::stats() const {
  TransportStats s = inner_->stats();
  s.fault_dropped_published = dropped_published_.load();
  s.fault_dropped_received = dropped_received_.load();
  return s;
}

}  // namespace rgbdmap::transport
