#pragma once
// LCM adapter (memq://, udpm://). One catch-all LCM subscription; our HandlerTable dispatches by name.
#include <memory>
#include <thread>

#include "handler_table.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "stats_counter.hpp"

typedef struct _lcm_t lcm_t;
typedef struct _lcm_recv_buf_t lcm_recv_buf_t;

namespace rgbdmap::transport {

class LcmTransport final : public Transport {
 public:
  static Result<std::unique_ptr<Transport>> create(const TransportOptions& options);
  ~LcmTransport() override;

  Status publish(const std::string& channel, const uint8_t* data, size_t size) override;
  Status subscribe(const std::string& channel, Handler handler) override;
  Status start() override;
  void stop() override;
  TransportStats stats() const override { return stats_.snapshot(); }

 private:
  LcmTransport(lcm_t* lcm, int wake_fd) : lcm_(lcm), wake_fd_(wake_fd) {}
  static void onMessage(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  void receiveLoop();

  lcm_t* lcm_;
  int wake_fd_;  // eventfd; written by stop() to wake poll()
  std::thread thread_;
  std::mutex lifecycle_mutex_;
  HandlerTable handlers_;
  StatsCounter stats_;
};

}  // namespace rgbdmap::transport
