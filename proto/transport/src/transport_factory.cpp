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

/// The DDS domain of a dds:// URL without its fault options, or the reason it cannot be used: a bad domain,
/// or no CYCLONEDDS_URI (Cyclone's built-in default multicasts discovery on every interface).
Result<int> ddsDomain(const std::string& url) {
  const std::string domain_text = queryValue(url, "domain", "0");
  char* end = nullptr;
  const long domain = std::strtol(domain_text.c_str(), &end, 10);
  if (end == domain_text.c_str() || *end != '\0' || domain < 0 || domain > 232)
    return Result<int>::failure("bad DDS domain '" + domain_text + "' in " + url);
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if ((uri == nullptr || *uri == '\0') && queryValue(url, "allow_default_config", "0") != "1")
    return Result<int>::failure(
        "CYCLONEDDS_URI is not set; point it at deploy/dds/cyclonedds-*.xml "
        "(or add allow_default_config=1 to the URL)");
  return static_cast<int>(domain);
}

/// The adapter URL without fault options; the reason when the URL cannot be used.
Result<std::string> checkedAdapterUrl(const std::string& url, FaultOptions* faults) {
  std::string inner = url;
  if (const std::string e = parseFaultOptions(&inner, faults); !e.empty())
    return Result<std::string>::failure(e + " in " + url);
  if (startsWith(inner, "memq://") || startsWith(inner, "udpm://")) return inner;
  if (startsWith(inner, "dds://")) {
    if (auto domain = ddsDomain(inner); !domain) return Result<std::string>::failure(domain.error());
    return inner;
  }
  return Result<std::string>::failure("unknown transport URL '" + url +
                                      "' (expected memq://, udpm://... or dds://?domain=N)");
}

}  // namespace

Status checkTransportUrl(const std::string& url) {
  FaultOptions faults;
  const Result<std::string> checked = checkedAdapterUrl(url, &faults);
  return checked ? Status::success() : Status::failure(checked.error());
}

TransportResult makeTransport(const TransportOptions& options) {
  FaultOptions faults;
  const Result<std::string> url = checkedAdapterUrl(options.url, &faults);
  if (!url) return TransportResult::failure(url.error());
  TransportOptions inner = options;
  inner.url = *url;
  TransportResult adapter = startsWith(inner.url, "dds://")
                                ? DdsTransport::create(inner, *ddsDomain(inner.url))
                                : LcmTransport::create(inner);
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
