#include "rgbdmap/dataset/trajectory.hpp"

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"

#include <cmath>
#include <cstdio>

namespace rgbdmap {

Result<Trajectory> parseTumTrajectory(const std::string& text, const std::string& source_name) {
  Trajectory out;
  for (const TextLine& line : dataLines(text)) {
    const std::string where = source_name + ":" + std::to_string(line.number) + ": ";
    if (line.fields.size() > 8) return Result<Trajectory>::failure(where + "expected 8 fields, got more");
    if (line.fields.size() != 8)
      return Result<Trajectory>::failure(where + "expected 8 fields (timestamp tx ty tz qx qy qz qw), got " +
                                         std::to_string(line.fields.size()));
    double v[8];
    for (int i = 0; i < 8; ++i) {
      const auto number = parseFiniteNumber(line.fields[i]);
      if (!number) return Result<Trajectory>::failure(where + number.error());
      v[i] = *number;
    }
    if (std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]) < 1e-6)
      return Result<Trajectory>::failure(where + "zero quaternion");
    out.push_back({v[0], se3::fromTum(v[1], v[2], v[3], v[4], v[5], v[6], v[7])});
  }
  return out;
}

Result<Trajectory> readTumTrajectory(const std::string& path) {
  const auto text = readTextFile(path);
  if (!text) return Result<Trajectory>::failure(text.error());
  return parseTumTrajectory(*text, path);
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
  std::string text = header.empty() ? std::string() : "# " + header + "\n";
  text += "# timestamp tx ty tz qx qy qz qw\n" + formatTumTrajectory(trajectory);
  return writeFileAtomic(path, text);
}

}  // namespace rgbdmap
