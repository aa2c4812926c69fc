#include "rgbdmap/intake/image_admission.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace rgbdmap {
namespace {

uint32_t readLe(const std::vector<uint8_t>& blob, size_t at, int bytes) {
  uint32_t v = 0;
  for (int b = 0; b < bytes; ++b) v |= uint32_t(blob[at + b]) << (8 * b);
  return v;
}

/// The blob's header against the camera, without touching its payload.
std::string blobRefused(const std::vector<uint8_t>& blob, const char* magic, const char* what,
                        const CameraIntrinsics& camera, const ImageLimits& limits) {
  const std::string name(what);
  if (blob.size() > limits.max_image_bytes)
    return name + " image of " + std::to_string(blob.size()) + " bytes, above server.max_image_bytes (" +
           std::to_string(limits.max_image_bytes) + ")";
  if (blob.size() < kImageBlobHeaderSize || std::memcmp(blob.data(), magic, 4) != 0)
    return name + " image without a valid header";
  const uint32_t width = readLe(blob, 6, 2), height = readLe(blob, 8, 2);
  if (width != uint32_t(camera.width) || height != uint32_t(camera.height))
    return name + " image declares " + std::to_string(width) + "x" + std::to_string(height) +
           ", the robot's camera is " + std::to_string(camera.width) + "x" + std::to_string(camera.height);
  if (readLe(blob, 12, 4) != blob.size() - kImageBlobHeaderSize)
    return name + " image payload length differs from its header";
  return "";
}

}  // namespace

std::string imagesRefusedBeforeDecode(const EncodedImages& images, const CameraIntrinsics& camera,
                                      const ImageLimits& limits) {
  const size_t pixels = size_t(std::max(camera.width, 0)) * size_t(std::max(camera.height, 0));
  if (pixels > limits.max_image_pixels)
    return "camera " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
           " above server.max_image_pixels (" + std::to_string(limits.max_image_pixels) + ")";
  if (images.width != camera.width || images.height != camera.height)
    return "image size " + std::to_string(images.width) + "x" + std::to_string(images.height) +
           " differs from the camera in the robot's Hello (" + std::to_string(camera.width) + "x" +
           std::to_string(camera.height) + ")";
  if (std::string r = blobRefused(images.depth, "RDMD", "depth", camera, limits); !r.empty()) return r;
  if (images.color_codec == ColorCodec::kNone)
    return images.color.empty() ? "" : "colour image present with colour codec none";
  return blobRefused(images.color, "RDMC", "colour", camera, limits);
}

}  // namespace rgbdmap
