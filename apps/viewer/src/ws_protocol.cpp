// The Foxglove WebSocket protocol's text operations (https://github.com/foxglove/ws-protocol, v1): the
// server's serverInfo and advertise on connect; the client's subscribe and unsubscribe. Anything else - text
// that is not JSON, unknown or unsupported ops, wrong field types, unknown channels - is answered with a
// status message (level 2 = error) and counted; the connection stays open.
#include <nlohmann/json.hpp>

#include "ws_server.hpp"

namespace rgbdmap::viewer {

using nlohmann::json;

void WsServer::sendServerInfo(ClientSession& session) {
  const json info = {{"op", "serverInfo"},
                     {"name", options_.name},
                     {"capabilities", json::array()},
                     {"supportedEncodings", json::array({"json"})},
                     {"metadata", json::object()},
                     {"sessionId", std::to_string(session.id())}};
  session.sendText(info.dump());
  json list = json::array();
  for (const ChannelInfo& c : channels_)
    list.push_back({{"id", c.id},
                    {"topic", c.topic},
                    {"encoding", "json"},
                    {"schemaName", c.schema_name},
                    {"schema", c.schema},
                    {"schemaEncoding", "jsonschema"}});
  session.sendText(json{{"op", "advertise"}, {"channels", std::move(list)}}.dump());
}

void WsServer::sendStatus(ClientSession& session, int level, const std::string& message) {
  session.sendText(json{{"op", "status"}, {"level", level}, {"message", message}}.dump());
}

void WsServer::handleText(ClientSession& session, const std::string& text) {
  const json op = json::parse(text, nullptr, false);
  if (op.is_discarded() || !op.is_object() || !op.contains("op") || !op["op"].is_string()) {
    ++malformed_;
    sendStatus(session, 2, "not a JSON object with an \"op\"");
    return;
  }
  const std::string name = op["op"].get<std::string>();
  if (name == "subscribe") {
    handleSubscribe(session, op);
  } else if (name == "unsubscribe") {
    handleUnsubscribe(session, op);
  } else {
    ++unknown_ops_;
    sendStatus(session, 2, "unsupported op \"" + name.substr(0, 64) + "\"");
  }
}

void WsServer::handleSubscribe(ClientSession& session, const json& op) {
  if (!op.contains("subscriptions") || !op["subscriptions"].is_array()) {
    ++malformed_;
    return sendStatus(session, 2, "subscribe: \"subscriptions\" must be an array");
  }
  for (const json& s : op["subscriptions"]) {
    if (!s.is_object() || !s.contains("id") || !s.contains("channelId") || !s["id"].is_number_unsigned() ||
        !s["channelId"].is_number_unsigned() || s["id"].get<uint64_t>() > UINT32_MAX) {
      ++malformed_;
      sendStatus(session, 2, "subscribe: each subscription needs unsigned \"id\" and \"channelId\"");
      continue;
    }
    const uint32_t id = s["id"].get<uint32_t>();
    const uint64_t channel_id = s["channelId"].get<uint64_t>();
    const ChannelInfo* info = channel_id <= UINT32_MAX ? channel(static_cast<uint32_t>(channel_id)) : nullptr;
    if (!info) {
      ++refused_subs_;
      sendStatus(session, 2, "subscribe: unknown channel " + std::to_string(channel_id));
      continue;
    }
    if (const std::string why = session.subscribe(id, info->id); !why.empty()) {
      ++refused_subs_;
      sendStatus(session, 2, "subscribe: " + why);
      continue;
    }
    if (info->incremental) {
      if (request_) request_(info->id);
      continue;
    }
    Latest latest;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = latest_.find(info->id);
      if (it == latest_.end()) continue;
      latest = it->second;
    }
    session.sendMessage(info->id, latest.payload, latest.utime > 0 ? latest.utime * 1000u : 0u, false);
  }
}

void WsServer::handleUnsubscribe(ClientSession& session, const json& op) {
  if (!op.contains("subscriptionIds") || !op["subscriptionIds"].is_array()) {
    ++malformed_;
    return sendStatus(session, 2, "unsubscribe: \"subscriptionIds\" must be an array");
  }
  for (const json& id : op["subscriptionIds"]) {
    if (!id.is_number_unsigned() || id.get<uint64_t>() > UINT32_MAX ||
        !session.unsubscribe(id.get<uint32_t>())) {
      ++refused_subs_;
      sendStatus(session, 1, "unsubscribe: no subscription " + id.dump().substr(0, 32));
    }
  }
}

}  // namespace rgbdmap::viewer
