// Debian's libcivetweb is built with USE_STACK_SIZE=102400: every civetweb worker thread gets a 100 KiB
// stack, and glibc carves the process's static TLS out of it. In `rgbdmap run` (Ceres pulls in glog and
// METIS, ~60 KiB of static TLS) that left ~40 KiB, and the first HTTP response overflowed it (SIGSEGV in
// vsnprintf under mg_printf). civetweb has no run-time option for it, so this executable-level definition
// interposes pthread_attr_setstacksize (civetweb's call resolves to it) and raises requests below 1 MiB to
// 1 MiB before calling the real function. Other callers asking for 1 MiB or more are unaffected.
#include <dlfcn.h>
#include <pthread.h>

#include <algorithm>

extern "C" int pthread_attr_setstacksize(pthread_attr_t* attr, size_t size) {
  using Real = int (*)(pthread_attr_t*, size_t);
  static const Real real = reinterpret_cast<Real>(dlsym(RTLD_NEXT, "pthread_attr_setstacksize"));
  constexpr size_t kMinStack = 1u << 20;
  return real ? real(attr, std::max(size, kMinStack)) : 0;
}

namespace rgbdmap::viewer {
/// Called by WsServer::start() so that this object file (and the definition above) is linked.
int civetwebStackFloor() { return 1 << 20; }
}  // namespace rgbdmap::viewer
