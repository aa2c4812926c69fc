#pragma once
// Refusing a keyframe's images before decoding them: the compressed blobs of rgbdmap/codec/image_codec.hpp
// declare their size in a 20-byte header (image_codec.hpp). Reading it costs nothing, decoding a forged
// 4096x4096 image costs ~84 MB and a second or more of the ingest worker. So before any pixel is decoded,
// the images must be of the camera the robot announced in its Hello, that camera must be at most
// max_image_pixels, and each compressed blob at most max_image_bytes (and exactly as long as its header
// says). Pure functions, any thread.
#include <cstddef>
#include <string>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/camera.hpp"

namespace rgbdmap {

struct ImageLimits {
  size_t max_image_pixels = 2048 * 2048;  ///< server.max_image_pixels: width * height of a robot's camera
  size_t max_image_bytes = 8u << 20;      ///< server.max_image_bytes: one compressed depth or colour blob
};

/// "" when the images may be decoded, else why not (the keyframe is refused with it).
std::string imagesRefusedBeforeDecode(const EncodedImages& images, const CameraIntrinsics& camera,
                                      const ImageLimits& limits);

}  // namespace rgbdmap
