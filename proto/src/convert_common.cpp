// Shared wire conversions: header and pose.
#include <cmath>

#include "convert_common.hpp"

namespace rgbdmap::msg::detail {

rgbdmap_lcm::header_t toWire(const Header& h) {
  rgbdmap_lcm::header_t w;
  w.schema_version = static_cast<int16_t>(h.schema_version);
  w.sender = h.sender;
  w.session = h.session;
  w.seq = h.seq;
  w.utime = h.utime;
  return w;
}

Header fromWire(const rgbdmap_lcm::header_t& w) {
  return Header{w.schema_version, w.sender, w.session, w.seq, w.utime};
}

rgbdmap_lcm::pose_t toWire(const SE3& T) {
  rgbdmap_lcm::pose_t w;
  const Eigen::Quaterniond q = se3::quat(T);
  for (int i = 0; i < 3; ++i) w.t[i] = T.translation()[i];
  w.q[0] = q.x();
  w.q[1] = q.y();
  w.q[2] = q.z();
  w.q[3] = q.w();
  return w;
}

Result<SE3> fromWire(const rgbdmap_lcm::pose_t& w, const char* name) {
  for (double v : w.t)
    if (!std::isfinite(v)) return Result<SE3>::failure(std::string(name) + ": non-finite translation");
  for (double v : w.q)
    if (!std::isfinite(v)) return Result<SE3>::failure(std::string(name) + ": non-finite quaternion");
  const Eigen::Quaterniond q(w.q[3], w.q[0], w.q[1], w.q[2]);
  if (std::abs(q.norm() - 1.0) > 1e-6)
    return Result<SE3>::failure(std::string(name) + ": non-unit quaternion");
  return se3::fromQuatTrans(q.normalized(), Vec3(w.t[0], w.t[1], w.t[2]));
}

}  // namespace rgbdmap::msg::detail
