#pragma once
// A real write failure without root: RLIMIT_FSIZE makes every write past `bytes` fail with EFBIG (SIGXFSZ
// is ignored while the limit is set), like a disk that filled up. Process-wide: hold it only around the
// writes that must fail. Restores the previous limit and signal disposition when it goes.
#include <signal.h>
#include <sys/resource.h>

namespace rgbdmap::testing {

class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    ::getrlimit(RLIMIT_FSIZE, &previous_);
    previous_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit = previous_;
    limit.rlim_cur = bytes;
    ok_ = ::setrlimit(RLIMIT_FSIZE, &limit) == 0;
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &previous_);
    ::signal(SIGXFSZ, previous_handler_);
  }
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

  bool ok() const { return ok_; }  ///< the limit is in force

 private:
  rlimit previous_{};
  sighandler_t previous_handler_ = SIG_DFL;
  bool ok_ = false;
};

}  // namespace rgbdmap::testing
