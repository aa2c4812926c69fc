#pragma once
// The viewer's one HTTP port (civetweb): the Foxglove WebSocket protocol (subprotocol
// foxglove.websocket.v1, JSON encoding) on any path, the built-in web page at / and three.js from Debian's
// libjs-three under /three/. Channels are fixed at start and advertised to every client; a client receives
// only the channels it subscribed to: on subscribing, the channel's latest message at once (late joiner),
// then every new one. Incremental channels (voxel deltas) start with a snapshot the owner is asked for.
// Clients are isolated from each other and from the map subscription (client_session.hpp).
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/viewer/client_session.hpp"

struct mg_context;
struct mg_connection;

namespace rgbdmap::viewer {

struct ChannelInfo {
  uint32_t id = 0;
  std::string topic, schema_name, schema;
  bool incremental = false;  ///< deltas after a snapshot (sendDelta / sendSnapshot)
};

struct WsServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8765;                                        ///< 0: any free port (port() tells which)
  std::string web_dir;                                    ///< index.html, viewer.js
  std::string three_dir = "/usr/share/javascript/three";  ///< Debian libjs-three
  int max_clients = 16;
  SessionLimits limits;
  std::string name = "rgbdmap-viewer";
};

struct WsServerStats {
  uint64_t clients = 0, connections = 0, refused_connections = 0;
  uint64_t messages_sent = 0, bytes_sent = 0, dropped_messages = 0, dropped_bytes = 0;
  uint64_t malformed = 0, unknown_ops = 0, refused_subscriptions = 0, http_requests = 0;
};

class WsServer {
 public:
  /// Asked (from any thread) for a snapshot of an incremental channel a client waits for.
  using SnapshotRequest = std::function<void(uint32_t channel)>;
  WsServer(WsServerOptions options, std::vector<ChannelInfo> channels, SnapshotRequest request);
  ~WsServer();  ///< stop()
  WsServer(const WsServer&) = delete;
  WsServer& operator=(const WsServer&) = delete;

  Status start();
  void stop();
  int port() const { return port_; }

  /// A channel's new latest message (kept for late joiners), sent to its subscribers.
  void publishLatest(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime);
  /// An incremental message, sent to subscribers that hold the previous state.
  void publishDelta(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime);
  /// A full state of an incremental channel: to the subscribers waiting for one, or to all (`everyone`).
  void publishSnapshot(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime,
                       bool everyone);
  /// True when a subscriber of `channel` waits for a snapshot.
  bool wantsSnapshot(uint32_t channel) const;
  WsServerStats stats() const;

  // civetweb callbacks (static trampolines in ws_server.cpp).
  int onConnect(const mg_connection* conn);
  void onReady(mg_connection* conn);
  int onData(mg_connection* conn, int bits, const char* data, size_t size);
  void onClose(const mg_connection* conn);
  int onHttp(mg_connection* conn);

 private:
  std::shared_ptr<ClientSession> sessionOf(const mg_connection* conn) const;
  void handleText(ClientSession& session, const std::string& text);
  void sendServerInfo(ClientSession& session);
  void handleSubscribe(ClientSession& session, const nlohmann::json& op);
  void handleUnsubscribe(ClientSession& session, const nlohmann::json& op);
  void sendStatus(ClientSession& session, int level, const std::string& message);
  void resend(ClientSession& session, uint32_t channel);
  const ChannelInfo* channel(uint32_t id) const;

  WsServerOptions options_;
  std::vector<ChannelInfo> channels_;
  SnapshotRequest request_;
  mg_context* ctx_ = nullptr;
  int port_ = 0;
  mutable std::mutex mutex_;
  std::map<const mg_connection*, std::shared_ptr<ClientSession>> sessions_;
  struct Latest {
    std::shared_ptr<const std::string> payload;
    int64_t utime = 0;
  };
  std::map<uint32_t, Latest> latest_;
  uint64_t next_session_ = 1;
  SessionCounters closed_counters_;  ///< of sessions that ended
  std::atomic<uint64_t> connections_{0}, refused_{0}, malformed_{0}, unknown_ops_{0}, refused_subs_{0},
      http_requests_{0};
};

}  // namespace rgbdmap::viewer
