#include "rgbdmap/common/trajectory.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace rgbdmap {

Result<Trajectory> parseTumTrajectory(const std::string& text, const std::string& source_name) {
  Trajectory out;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ls(line);
    double v[8];
    int n = 0;
    std::string token;
    while (ls >> token) {
      if (n == 8)
        return Result<Trajectory>::failure(source_name + ":" + std::to_string(line_no) +
                                           ": expected 8 fields, got more");
      char* end = nullptr;
      v[n] = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0')
        return Result<Trajectory>::failure(source_name + ":" + std::to_string(line_no) + ": '" + token +
                                           "' is not a number");
      if (!std::isfinite(v[n]))
        return Result<Trajectory>::failure(source_name + ":" + std::to_string(line_no) +
                                           ": non-finite value");
      ++n;
    }
    if (n != 8)
      return Result<Trajectory>::failure(source_name + ":" + std::to_string(line_no) +
                                         ": expected 8 fields (" + "timestamp tx ty tz qx qy qz qw), got " +
                                         std::to_string(n));
    const double qnorm = std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
    if (qnorm < 1e-6)
      return Result<Trajectory>::failure(source_name + ":" + std::to_string(line_no) + ": zero quaternion");
    out.push_back({v[0], se3::fromTum(v[1], v[2], v[3], v[4], v[5], v[6], v[7])});
  }
  return out;
}

Result<Trajectory> readTumTrajectory(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Result<Trajectory>::failure(path + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  return parseTumTrajectory(ss.str(), path);
}

std::string formatTumTrajectory(const Trajectory& trajectory) {
  std::string out;
  char buf[256];
  for (const auto& p : trajectory) {
    const Eigen::Quaterniond q = se3::quat(p.T_world_cam);
    const Vec3 t = p.T_world_cam.translation();
    std::snprintf(buf, sizeof buf, "%.6f %.7f %.7f %.7f %.9f %.9f %.9f %.9f\n", p.timestamp, t.x(), t.y(),
                  t.z(), q.x(), q.y(), q.z(), q.w());
    out += buf;
  }
  return out;
}

Status writeTumTrajectory(const std::string& path, const Trajectory& trajectory, const std::string& header) {
  std::ofstream f(path);
  if (!f) return Status::failure(path + ": cannot open for writing");
  if (!header.empty()) f << "# " << header << "\n";
  f << "# timestamp tx ty tz qx qy qz qw\n" << formatTumTrajectory(trajectory);
  if (!f) return Status::failure(path + ": write failed");
  return Status::success();
}

}  // namespace rgbdmap
