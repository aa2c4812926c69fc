// WsServer: civetweb set-up, the connection lifecycle, publishing to the sessions and the static files.
// The protocol's client operations are in ws_protocol.cpp.
#include "ws_server.hpp"

#include <civetweb.h>

#include <algorithm>
#include <cctype>
#include <cstring>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::viewer {

int civetwebStackFloor();  // thread_stack.cpp

namespace {

WsServer* serverOf(const mg_connection* conn) {
  return static_cast<WsServer*>(mg_get_user_data(mg_get_context(conn)));
}
int connectTrampoline(const mg_connection* conn, void*) { return serverOf(conn)->onConnect(conn); }
void readyTrampoline(mg_connection* conn, void*) { serverOf(conn)->onReady(conn); }
int dataTrampoline(mg_connection* conn, int bits, char* data, size_t size, void*) {
  return serverOf(conn)->onData(conn, bits, data, size);
}
void closeTrampoline(const mg_connection* conn, void*) { serverOf(conn)->onClose(conn); }
int httpTrampoline(mg_connection* conn, void*) { return serverOf(conn)->onHttp(conn); }
int logTrampoline(const mg_connection*, const char* message) {
  log::debug("viewer http: ", message);
  return 1;  // handled: civetweb prints nothing itself
}

const char* kSubprotocols[] = {"foxglove.websocket.v1"};
mg_websocket_subprotocols kSubprotocolList = {1, kSubprotocols};

uint64_t toNs(int64_t utime) { return utime > 0 ? static_cast<uint64_t>(utime) * 1000u : 0u; }

/// A relative path made only of [A-Za-z0-9_.-/] segments, none of them "." or "..".
bool safeRelativePath(const std::string& p) {
  if (p.empty() || p.front() == '/') return false;
  size_t start = 0;
  while (start <= p.size()) {
    const size_t end = std::min(p.find('/', start), p.size());
    const std::string seg = p.substr(start, end - start);
    if (seg.empty() || seg == "." || seg == "..") return false;
    for (char c : seg)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
    start = end + 1;
  }
  return true;
}

}  // namespace

WsServer::WsServer(WsServerOptions options, std::vector<ChannelInfo> channels, SnapshotRequest request)
    : options_(std::move(options)), channels_(std::move(channels)), request_(std::move(request)) {}

WsServer::~WsServer() { stop(); }

Status WsServer::start() {
  if (ctx_) return Status::failure("viewer server already started");
  log::debug("viewer: civetweb worker stacks of at least ", civetwebStackFloor(), " bytes");
  mg_init_library(0);
  const std::string ports = options_.bind + ":" + std::to_string(options_.port);
  const std::string threads = std::to_string(options_.max_clients + 4);
  const char* config[] = {"listening_ports",
                          ports.c_str(),
                          "num_threads",
                          threads.c_str(),
                          "request_timeout_ms",
                          "10000",
                          "websocket_timeout_ms",
                          "3600000",
                          "enable_websocket_ping_pong",
                          "yes",
                          nullptr};
  mg_callbacks callbacks;
  std::memset(&callbacks, 0, sizeof(callbacks));
  callbacks.log_message = logTrampoline;
  ctx_ = mg_start(&callbacks, this, config);
  if (!ctx_) {
    mg_exit_library();
    return Status::failure("cannot listen on " + ports + " (in use, or not a local address?)");
  }
  mg_set_websocket_handler_with_subprotocols(ctx_, "/", &kSubprotocolList, connectTrampoline, readyTrampoline,
                                             dataTrampoline, closeTrampoline, nullptr);
  mg_set_request_handler(ctx_, "/", httpTrampoline, nullptr);
  mg_server_port server_ports[4];
  const int n = mg_get_server_ports(ctx_, 4, server_ports);
  port_ = n > 0 ? server_ports[0].port : options_.port;
  return Status::success();
}

void WsServer::stop() {
  if (!ctx_) return;
  mg_stop(ctx_);  // closes every connection (onClose joins each session's writer)
  ctx_ = nullptr;
  mg_exit_library();
  std::lock_guard<std::mutex> lock(mutex_);
  sessions_.clear();
}

int WsServer::onConnect(const mg_connection*) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (static_cast<int>(sessions_.size()) >= options_.max_clients) {
    ++refused_;
    return 1;  // refuse: civetweb answers the handshake with an error
  }
  return 0;
}

void WsServer::onReady(mg_connection* conn) {
  ClientSession::Writer writer = [conn](bool binary, const std::string& bytes) {
    const int opcode = binary ? MG_WEBSOCKET_OPCODE_BINARY : MG_WEBSOCKET_OPCODE_TEXT;
    return mg_websocket_write(conn, opcode, bytes.data(), bytes.size()) > 0;
  };
  std::shared_ptr<ClientSession> session;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    session =
        std::make_shared<ClientSession>(next_session_++, options_.limits, std::move(writer),
                                        [this](ClientSession& s, uint32_t channel) { resend(s, channel); });
    sessions_[conn] = session;
  }
  ++connections_;
  session->start();
  sendServerInfo(*session);
}

int WsServer::onData(mg_connection* conn, int bits, const char* data, size_t size) {
  const int opcode = bits & 0x0f;
  if (opcode == MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE) return 0;
  if (opcode == MG_WEBSOCKET_OPCODE_PING || opcode == MG_WEBSOCKET_OPCODE_PONG) return 1;
  const std::shared_ptr<ClientSession> session = sessionOf(conn);
  if (!session) return 0;
  if (opcode == MG_WEBSOCKET_OPCODE_TEXT) {
    handleText(*session, std::string(data, size));
  } else {  // binary (clientMessageData, ...) or a continuation: this server accepts no client publishing
    ++malformed_;
    sendStatus(*session, 2, "binary client messages are not supported");
  }
  return 1;
}

void WsServer::onClose(const mg_connection* conn) {
  std::shared_ptr<ClientSession> session;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = sessions_.find(conn);
    if (it == sessions_.end()) return;
    session = it->second;
    sessions_.erase(it);
  }
  session->close();  // joins its writer: no write on `conn` after this returns
  const SessionCounters c = session->counters();
  std::lock_guard<std::mutex> lock(mutex_);
  closed_counters_.messages_sent += c.messages_sent;
  closed_counters_.bytes_sent += c.bytes_sent;
  closed_counters_.dropped_messages += c.dropped_messages;
  closed_counters_.dropped_bytes += c.dropped_bytes;
}

int WsServer::onHttp(mg_connection* conn) {
  ++http_requests_;
  const mg_request_info* info = mg_get_request_info(conn);
  const std::string uri = info && info->local_uri ? info->local_uri : "/";
  if (!info || std::strcmp(info->request_method, "GET") != 0) {
    mg_send_http_error(conn, 405, "%s", "only GET");
    return 405;
  }
  std::string path;
  if (uri == "/" || uri == "/index.html") {
    path = options_.web_dir + "/index.html";
  } else if (uri == "/viewer.js") {
    path = options_.web_dir + "/viewer.js";
  } else if (uri.rfind("/three/", 0) == 0 && safeRelativePath(uri.substr(7))) {
    path = options_.three_dir + "/" + uri.substr(7);
  } else {
    mg_send_http_error(conn, 404, "%s", "not found");
    return 404;
  }
  mg_send_file(conn, path.c_str());
  return 200;
}

std::shared_ptr<ClientSession> WsServer::sessionOf(const mg_connection* conn) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = sessions_.find(conn);
  return it == sessions_.end() ? nullptr : it->second;
}

const ChannelInfo* WsServer::channel(uint32_t id) const {
  for (const ChannelInfo& c : channels_)
    if (c.id == id) return &c;
  return nullptr;
}

void WsServer::publishLatest(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_[channel] = {payload, utime};
  for (const auto& [conn, session] : sessions_) session->sendMessage(channel, payload, toNs(utime), false);
}

void WsServer::publishDelta(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [conn, session] : sessions_) session->sendMessage(channel, payload, toNs(utime), true);
}

void WsServer::publishSnapshot(uint32_t channel, std::shared_ptr<const std::string> payload, int64_t utime,
                               bool everyone) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_[channel] = {payload, utime};
  for (const auto& [conn, session] : sessions_)
    session->sendSnapshot(channel, payload, toNs(utime), everyone);
}

bool WsServer::wantsSnapshot(uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [conn, session] : sessions_)
    if (session->awaitsSnapshot(channel)) return true;
  return false;
}

void WsServer::resend(ClientSession& session, uint32_t channel) {
  const ChannelInfo* info = this->channel(channel);
  if (info && info->incremental) {
    session.awaitSnapshot(channel);
    if (request_) request_(channel);
    return;
  }
  Latest latest;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = latest_.find(channel);
    if (it == latest_.end()) return;
    latest = it->second;
  }
  session.sendMessage(channel, latest.payload, toNs(latest.utime), false);
}

WsServerStats WsServer::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  WsServerStats s;
  SessionCounters total = closed_counters_;
  for (const auto& [conn, session] : sessions_) {
    const SessionCounters c = session->counters();
    total.messages_sent += c.messages_sent;
    total.bytes_sent += c.bytes_sent;
    total.dropped_messages += c.dropped_messages;
    total.dropped_bytes += c.dropped_bytes;
  }
  s.clients = sessions_.size();
  s.connections = connections_;
  s.refused_connections = refused_;
  s.messages_sent = total.messages_sent;
  s.bytes_sent = total.bytes_sent;
  s.dropped_messages = total.dropped_messages;
  s.dropped_bytes = total.dropped_bytes;
  s.malformed = malformed_;
  s.unknown_ops = unknown_ops_;
  s.refused_subscriptions = refused_subs_;
  s.http_requests = http_requests_;
  return s;
}

}  // namespace rgbdmap::viewer
