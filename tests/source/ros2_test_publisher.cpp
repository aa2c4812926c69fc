// ros2_test_publisher: a TUM folder published as a ROS 2 camera would (realsense2_camera's topics over
// Cyclone DDS: bgr8 colour, 32FC1 depth in metres, camera_info with each colour image), at a frame rate,
// once at least one reader matched. For the ros2: source's tests. Exit 0 when every frame was published.
// Usage: ros2_test_publisher DIR [--rate HZ] [--frames N] [--wait-readers S] [--domain N]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/source/ros2_topics.hpp"
#include "source/ros_test_messages.hpp"

int main(int argc, char** argv) {
  using namespace rgbdmap;
  if (argc < 2)
    return std::fprintf(stderr,
                        "usage: ros2_test_publisher DIR [--rate HZ] [--frames N] "
                        "[--wait-readers S] [--domain N]\n"),
           2;
  double rate = 15, wait_s = 20;
  size_t frames = 0;
  int domain = 0;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--rate")
      rate = std::atof(argv[i + 1]);
    else if (key == "--frames")
      frames = static_cast<size_t>(std::atol(argv[i + 1]));
    else if (key == "--wait-readers")
      wait_s = std::atof(argv[i + 1]);
    else if (key == "--domain")
      domain = std::atoi(argv[i + 1]);
    else
      return std::fprintf(stderr, "ros2_test_publisher: unknown option %s\n", key.c_str()), 2;
  }
  auto yaml = readDatasetCamera(argv[1]);
  if (!yaml || !*yaml) return std::fprintf(stderr, "ros2_test_publisher: no camera.yaml in %s\n", argv[1]), 1;
  const CameraIntrinsics camera = **yaml;
  DatasetOptions options;
  options.depth_scale = camera.depth_scale;
  auto dataset = TumDataset::open(argv[1], options);
  if (!dataset) return std::fprintf(stderr, "ros2_test_publisher: %s\n", dataset.error().c_str()), 1;
  auto publisher = ros2::ImagePublisher::create(domain, {});
  if (!publisher) return std::fprintf(stderr, "ros2_test_publisher: %s\n", publisher.error().c_str()), 1;
  const auto start = std::chrono::steady_clock::now();
  while ((*publisher)->matchedReaders() < 1) {
    if (std::chrono::steady_clock::now() - start > std::chrono::duration<double>(wait_s))
      return std::fprintf(stderr, "ros2_test_publisher: no reader within %.0f s\n", wait_s), 1;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const size_t n = frames ? std::min(frames, dataset->size()) : dataset->size();
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = std::chrono::steady_clock::now();
  for (size_t i = 0; i < n; ++i) {
    auto frame = dataset->load(i);
    if (!frame) return std::fprintf(stderr, "ros2_test_publisher: %s\n", frame.error().c_str()), 1;
    const FrameEntry& e = dataset->entry(i);
    const Status s[3] = {
        (*publisher)->publishInfo(testing::cameraInfoFor(camera, e.rgb_timestamp)),
        (*publisher)->publishColor(ros1::imageFromMat(frame->color, "bgr8", e.rgb_timestamp)),
        (*publisher)
            ->publishDepth(
                ros1::imageFromMat(testing::depthAsEncoding(frame->depth, frame->depth_scale, "32FC1"),
                                   "32FC1", e.depth_timestamp))};
    for (const Status& st : s)
      if (!st) return std::fprintf(stderr, "ros2_test_publisher: %s\n", st.error().c_str()), 1;
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  std::fprintf(stderr, "ros2_test_publisher: published %zu frames\n", n);
  return 0;
}
