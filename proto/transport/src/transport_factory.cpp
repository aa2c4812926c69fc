// makeTransport: picks the adapter from the URL scheme.
#include <cstdlib>

#include "dds_transport.hpp"
#include "fault_transport.hpp"
#include "lcm_transport.hpp"

namespace rgbdmap::transport {
namespace {

using TransportResult = Result<std::unique_ptr<Transport>>;

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

/// Value of `key` in the URL's query ("dds://?domain=3&x=y"), or `fallback`.
std::string queryValue(const std::string& url, const std::string& key, const std::string& fallback) {
  const auto q = url.find('?');
  if (q == std::string::npos) return fallback;
  size_t pos = q + 1;
  while (pos < url.size()) {
    const auto end = std::min(url.find('&', pos), url.size());
    const std::string item = url.substr(pos, end - pos);
    if (startsWith(item, key + "=")) return item.substr(key.size() + 1);
    pos = end + 1;
  }
  return fallback;
}

TransportResult makeDds(const TransportOptions& options) {
  const std::string domain_text = queryValue(options.url, "domain", "0");
  char* end = nullptr;
  const long domain = std::strtol(domain_text.c_str(), &end, 10);
  if (end == domain_text.c_str() || *end != '\0' || domain < 0 || domain > 232) {
    return TransportResult::failure("bad DDS domain '" + domain_text + "' in " + options.url);
  }
  // Cyclone's built-in default multicasts discovery on every interface; insist on an explicit config.
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if ((uri == nullptr || *uri == '\0') && queryValue(options.url, "allow_default_config", "0") != "1") {
    return TransportResult::failure(
        "CYCLONEDDS_URI is not set; point it at deploy/dds/cyclonedds-*.xml "
        "(or add allow_default_config=1 to the URL)");
  }
  return DdsTransport::create(options, static_cast<int>(domain));
}

TransportResult makeAdapter(const TransportOptions& options) {
  if (startsWith(options.url, "memq://") || startsWith(options.url, "udpm://")) {
    return LcmTransport::create(options);
  }
  if (startsWith(options.url, "dds://")) return makeDds(options);
  return TransportResult::failure("unknown transport URL '" + options.url +
                                  "' (expected memq://, udpm://... or dds://?domain=N)");
}

}  // namespace

TransportResult makeTransport(const TransportOptions& options) {
  TransportOptions inner = options;
  FaultOptions faults;
  if (const std::string e = parseFaultOptions(&inner.url, &faults); !e.empty())
    return TransportResult::failure(e + " in " + options.url);
  TransportResult adapter = makeAdapter(inner);
  if (!adapter || !faults.enabled()) return adapter;
  return TransportResult(
      std::unique_ptr<Transport>(new FaultInjectingTransport(std::move(*adapter), faults)));
}

TransportResult makeTransport(const std::string& url) {
  TransportOptions options;
  options.url = url;
  return makeTransport(options);
}

}  // namespace rgbdmap::transport
