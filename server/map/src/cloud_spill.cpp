#include "cloud_spill.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

namespace rgbdmap::detail {
namespace {

constexpr uint32_t kMagic = 0x43534b52;  // "RKSC"

struct Header {
  uint32_t magic = kMagic;
  uint32_t points = 0;
  int64_t keyframe_id = 0;
  uint32_t has_colors = 0;
  uint32_t checksum = 0;  ///< FNV-1a over the payload
};

uint32_t fnv1a(const uint8_t* data, size_t n) {
  uint32_t h = 2166136261u;
  for (size_t i = 0; i < n; ++i) h = (h ^ data[i]) * 16777619u;
  return h;
}

}  // namespace

Result<std::unique_ptr<CloudSpill>> CloudSpill::open(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd < 0)
    return Result<std::unique_ptr<CloudSpill>>::failure("cloud spill file in " + dir + ": " +
                                                        std::strerror(errno));
  return std::unique_ptr<CloudSpill>(new CloudSpill(fd));
}

CloudSpill::~CloudSpill() { ::close(fd_); }

Result<CloudSpill::Ref> CloudSpill::write(const KeyframeCloud& cloud) {
  Header h;
  h.points = static_cast<uint32_t>(cloud.points_cam.size());
  h.keyframe_id = cloud.keyframe_id;
  h.has_colors = cloud.colors_rgb.empty() ? 0u : 1u;
  const size_t point_bytes = cloud.points_cam.size() * 3 * sizeof(float);
  const size_t color_bytes = h.has_colors ? cloud.colors_rgb.size() * 3 : 0;
  std::vector<uint8_t> buf(sizeof(Header) + point_bytes + color_bytes);
  uint8_t* payload = buf.data() + sizeof(Header);
  for (size_t i = 0; i < cloud.points_cam.size(); ++i)
    std::memcpy(payload + i * 3 * sizeof(float), cloud.points_cam[i].data(), 3 * sizeof(float));
  for (size_t i = 0; i < cloud.colors_rgb.size() && h.has_colors; ++i)
    std::memcpy(payload + point_bytes + i * 3, cloud.colors_rgb[i].data(), 3);
  h.checksum = fnv1a(payload, point_bytes + color_bytes);
  std::memcpy(buf.data(), &h, sizeof(Header));
  std::lock_guard<std::mutex> lock(append_mutex_);
  const uint64_t offset = end_.load();
  size_t done = 0;
  while (done < buf.size()) {
    const ssize_t n = ::pwrite(fd_, buf.data() + done, buf.size() - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return Result<Ref>::failure(std::string("cloud spill: write: ") + std::strerror(errno));
    done += static_cast<size_t>(n);
  }
  end_ = offset + buf.size();
  return Ref{offset, buf.size()};
}

Result<std::shared_ptr<const KeyframeCloud>> CloudSpill::read(const Ref& ref, int64_t keyframe_id) const {
  using R = Result<std::shared_ptr<const KeyframeCloud>>;
  if (ref.bytes < sizeof(Header) || ref.offset + ref.bytes > end_.load())
    return R::failure("cloud spill: keyframe " + std::to_string(keyframe_id) + ": no such record");
  std::vector<uint8_t> buf(ref.bytes);
  size_t done = 0;
  while (done < buf.size()) {
    const ssize_t n =
        ::pread(fd_, buf.data() + done, buf.size() - done, static_cast<off_t>(ref.offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      return R::failure(std::string("cloud spill: read: ") + (n < 0 ? std::strerror(errno) : "short"));
    done += static_cast<size_t>(n);
  }
  Header h;
  std::memcpy(&h, buf.data(), sizeof(Header));
  const size_t point_bytes = size_t{h.points} * 3 * sizeof(float);
  const size_t color_bytes = h.has_colors ? size_t{h.points} * 3 : 0;
  if (h.magic != kMagic || h.keyframe_id != keyframe_id ||
      sizeof(Header) + point_bytes + color_bytes != ref.bytes ||
      fnv1a(buf.data() + sizeof(Header), point_bytes + color_bytes) != h.checksum)
    return R::failure("cloud spill: keyframe " + std::to_string(keyframe_id) + ": record is corrupt");
  auto cloud = std::make_shared<KeyframeCloud>();
  cloud->keyframe_id = keyframe_id;
  cloud->points_cam.resize(h.points);
  const uint8_t* payload = buf.data() + sizeof(Header);
  for (size_t i = 0; i < h.points; ++i)
    std::memcpy(cloud->points_cam[i].data(), payload + i * 3 * sizeof(float), 3 * sizeof(float));
  if (h.has_colors) {
    cloud->colors_rgb.resize(h.points);
    for (size_t i = 0; i < h.points; ++i)
      std::memcpy(cloud->colors_rgb[i].data(), payload + point_bytes + i * 3, 3);
  }
  return std::shared_ptr<const KeyframeCloud>(std::move(cloud));
}

}  // namespace rgbdmap::detail
