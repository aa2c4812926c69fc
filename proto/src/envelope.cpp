// Envelope encode/sign and open/verify.
#include <cstring>

#include "convert_common.hpp"
#include "hmac.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap_lcm/envelope_t.hpp"

namespace rgbdmap::msg {
namespace {

Result<OpenedEnvelope> reject(RejectCounters* counters, RejectReason reason, const std::string& detail = "") {
  std::string text = toString(reason);
  if (!detail.empty()) text += ": " + detail;
  if (counters) counters->add(reason, detail);
  return Result<OpenedEnvelope>::failure(text);
}

/// Size of an envelope with an empty payload and a one-character sender: nothing shorter can be one.
size_t minimumEnvelopeSize() {
  rgbdmap_lcm::envelope_t e{};
  e.header.sender = "x";
  e.payload_size = 0;
  return static_cast<size_t>(e.getEncodedSize());
}

RejectReason classifyDecodeError(const std::string& error) {
  if (error.rfind("too large", 0) == 0) return RejectReason::kTooLarge;
  if (error.rfind("truncated", 0) == 0) return RejectReason::kTruncated;
  return RejectReason::kMalformed;
}

}  // namespace

Result<Bytes> encodeEnvelope(MessageType type, const Header& header, const Bytes& payload, const Bytes& key) {
  if (Status s = validate(header); !s) return Result<Bytes>::failure(s.error());
  if (payload.size() > static_cast<size_t>(kMaxEnvelopeBytes) - 1024)
    return Result<Bytes>::failure("payload too large");
  rgbdmap_lcm::envelope_t e{};
  e.header = detail::toWire(header);
  e.type = static_cast<int16_t>(type);
  e.payload_size = detail::count(payload);
  e.payload = payload;
  Bytes out = detail::encodeWire(e);  // mac is all zero here
  if (key.empty()) return out;
  detail::Mac mac;
  if (!detail::hmacSha256(key, out.data(), out.size() - kMacBytes, &mac))
    return Result<Bytes>::failure("HMAC failed");
  std::memcpy(out.data() + out.size() - kMacBytes, mac.data(), kMacBytes);  // mac is the last field
  return out;
}

Result<OpenedEnvelope> openEnvelope(const uint8_t* data, size_t size, const KeyStore& keys,
                                    ReplayGuard* guard, RejectCounters* counters, RejectNote* note) {
  static const size_t min_size = minimumEnvelopeSize();
  std::string claimed;  // the header's sender, once decoded
  auto fail = [&](RejectReason reason, const std::string& detail = "") {
    if (note) *note = RejectNote{reason, claimed};
    return reject(counters, reason, detail);
  };
  if (size > static_cast<size_t>(kMaxEnvelopeBytes)) return fail(RejectReason::kTooLarge);
  if (size < min_size) return fail(RejectReason::kTruncated, std::to_string(size) + " bytes");
  Result<rgbdmap_lcm::envelope_t> e = detail::decodeWire<rgbdmap_lcm::envelope_t>(data, size);
  if (!e) return fail(classifyDecodeError(e.error()), e.error());
  OpenedEnvelope out;
  out.header = detail::fromWire(e->header);
  claimed = out.header.sender;
  if (out.header.schema_version != kSchemaVersion)
    return fail(RejectReason::kWrongSchemaVersion, std::to_string(out.header.schema_version));
  if (!isKnownType(e->type)) return fail(RejectReason::kUnknownType, std::to_string(e->type));
  out.type = static_cast<MessageType>(e->type);
  if (!isValidId(out.header.sender)) return fail(RejectReason::kInvalidSender);
  if (Status s = validate(out.header); !s) return fail(RejectReason::kMalformed, s.error());
  const Bytes* key = keys.find(out.header.sender);
  if (key) {
    detail::Mac mac;
    if (!detail::hmacSha256(*key, data, size - kMacBytes, &mac) ||
        !detail::equalConstantTime(mac.data(), data + size - kMacBytes, kMacBytes))
      return fail(RejectReason::kBadSignature);
    out.authenticated = true;
  } else if (!keys.isOpen()) {
    return fail(RejectReason::kUnknownSender, out.header.sender);
  }
  if (guard) {
    if (Status s = guard->check(out.header, static_cast<int>(out.type)); !s)
      return fail(RejectReason::kReplayedSeq, s.error());
  }
  out.payload = std::move(e->payload);
  return out;
}

}  // namespace rgbdmap::msg

namespace rgbdmap::msg {

Signer::Signer(std::string sender, Bytes key, int64_t session, int64_t first_seq)
    : sender_(std::move(sender)), key_(std::move(key)), session_(session), next_seq_(first_seq) {}

}  // namespace rgbdmap::msg
