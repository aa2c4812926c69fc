// make_test_bag: a TUM folder into a ROS 1 bag (tests/source/bag_test_writer.hpp), for the command-line
// tests. usage: make_test_bag DIR OUT.bag [--depth 32FC1|16UC1|ENC] [--color rgb8|bgr8|mono8] [--no-depth]
//        [--no-info] [--frames N]
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "bag_test_writer.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: make_test_bag DIR OUT.bag [--depth E] [--color E] [--no-depth] [--no-info] "
                 "[--frames N]\n");
    return 2;
  }
  rgbdmap::testing::BagWriteOptions o;
  for (int i = 3; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--depth") && has_value)
      o.depth_encoding = argv[++i];
    else if (!std::strcmp(argv[i], "--color") && has_value)
      o.color_encoding = argv[++i];
    else if (!std::strcmp(argv[i], "--compression") && has_value)
      o.compression = argv[++i];
    else if (!std::strcmp(argv[i], "--frames") && has_value)
      o.max_frames = static_cast<size_t>(std::atol(argv[++i]));
    else if (!std::strcmp(argv[i], "--no-depth"))
      o.write_depth = false;
    else if (!std::strcmp(argv[i], "--no-info"))
      o.write_info = false;
    else
      return std::fprintf(stderr, "make_test_bag: unknown argument %s\n", argv[i]), 2;
  }
  auto camera = rgbdmap::readDatasetCamera(argv[1]);
  if (!camera || !camera->has_value())
    return std::fprintf(stderr, "make_test_bag: %s needs a camera.yaml\n", argv[1]), 1;
  const rgbdmap::Status s = rgbdmap::testing::writeTumFolderAsBag(argv[1], argv[2], **camera, o);
  if (!s) return std::fprintf(stderr, "make_test_bag: %s\n", s.error().c_str()), 1;
  return 0;
}
