// LCM adapter: lcm_publish on the caller's thread; a receive thread waits in poll() on LCM's file
// descriptor and an eventfd that stop() signals, and calls lcm_handle() when LCM has data.
#include "lcm_transport.hpp"

#include <lcm/lcm.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::transport {
namespace {
log::RateLimiter g_receive_log(1.0);
log::RateLimiter g_send_log(1.0);
}  // namespace

Result<std::unique_ptr<Transport>> LcmTransport::create(const TransportOptions& options) {
  using R = Result<std::unique_ptr<Transport>>;
  lcm_t* lcm = lcm_create(options.url.c_str());
  if (lcm == nullptr) return R::failure("lcm_create failed for '" + options.url + "'");
  const int wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) {
    lcm_destroy(lcm);
    return R::failure(std::string("eventfd: ") + std::strerror(errno));
  }
  std::unique_ptr<LcmTransport> t(new LcmTransport(lcm, wake_fd));
  lcm_subscription_t* sub = lcm_subscribe(lcm, ".*", &LcmTransport::onMessage, t.get());
  if (sub == nullptr) return R::failure("lcm_subscribe failed");
  lcm_subscription_set_queue_capacity(sub, options.lcm_queue_capacity);
  return R(std::unique_ptr<Transport>(std::move(t)));
}

LcmTransport::~LcmTransport() {
  stop();
  lcm_destroy(lcm_);
  close(wake_fd_);
}

Status LcmTransport::publish(const std::string& channel, const uint8_t* data, size_t size) {
  if (size > UINT32_MAX) return Status::failure("message too large for LCM");
  if (lcm_publish(lcm_, channel.c_str(), data, static_cast<unsigned int>(size)) != 0) {
    stats_.send_errors.fetch_add(1, std::memory_order_relaxed);
    uint64_t suppressed = 0;
    if (g_send_log.allow(&suppressed)) {
      log::warn("lcm_publish failed on ", channel, " (", size, " bytes; ", suppressed, " suppressed)");
    }
    return Status::failure("lcm_publish failed on " + channel);
  }
  stats_.onSent(size);
  return Status::success();
}

Status LcmTransport::subscribe(const std::string& channel, Handler handler) {
  if (channel.empty() || !handler) return Status::failure("subscribe needs a channel and a handler");
  handlers_.add(channel, std::move(handler));
  return Status::success();
}

void LcmTransport::onMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* self) {
  auto* t = static_cast<LcmTransport*>(self);
  const std::string name(channel);
  t->stats_.onReceived(rbuf->data_size);
  const auto handlers = t->handlers_.matching(name);
  if (handlers.empty()) {
    t->stats_.dropped.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  for (const auto& h : handlers) (*h)(name, static_cast<const uint8_t*>(rbuf->data), rbuf->data_size);
}

Status LcmTransport::start() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (thread_.joinable()) return Status::success();
  uint64_t drain = 0;
  (void)!read(wake_fd_, &drain, sizeof(drain));  // forget a stop() from an earlier run
  thread_ = std::thread([this] { receiveLoop(); });
  return Status::success();
}

void LcmTransport::stop() {
  std::lock_guard<std::mutex> lock(lifecycle_mutex_);
  if (!thread_.joinable()) return;
  const uint64_t one = 1;
  (void)!write(wake_fd_, &one, sizeof(one));
  thread_.join();
}

void LcmTransport::receiveLoop() {
  pollfd fds[2] = {{lcm_get_fileno(lcm_), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  int consecutive_failures = 0;
  for (;;) {
    fds[0].revents = fds[1].revents = 0;
    const int n = poll(fds, 2, -1);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 || (fds[1].revents & POLLIN) != 0) return;
    if ((fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
      log::error("LCM file descriptor failed; receive thread stops");
      return;
    }
    if ((fds[0].revents & POLLIN) == 0) continue;
    if (lcm_handle(lcm_) == 0) {
      consecutive_failures = 0;
      continue;
    }
    uint64_t suppressed = 0;
    if (g_receive_log.allow(&suppressed)) log::warn("lcm_handle failed (", suppressed, " suppressed)");
    if (++consecutive_failures >= 1000) {  // a broken socket would otherwise spin here
      log::error("lcm_handle keeps failing; receive thread stops");
      return;
    }
  }
}

}  // namespace rgbdmap::transport
