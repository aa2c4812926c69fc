// png_colours IMAGE.png BACKGROUND_HEX COLOUR_HEX...: prints the image size, how many pixels differ from
// the background (any channel by more than 24) and, per colour, how many pixels are within 40 of it in every
// channel ("size 1280x800 non_background 81234 #e6194b 812 #3cb44b 655"). For the viewer's page test.
#include <cstdio>
#include <cstdlib>
#include <string>

#include <opencv2/imgcodecs.hpp>

namespace {

cv::Vec3b bgrOf(const std::string& hex) {
  const long v = std::strtol(hex.c_str() + (hex[0] == '#' ? 1 : 0), nullptr, 16);
  return cv::Vec3b(static_cast<uchar>(v & 0xff), static_cast<uchar>((v >> 8) & 0xff),
                   static_cast<uchar>((v >> 16) & 0xff));
}

bool near(const cv::Vec3b& a, const cv::Vec3b& b, int tolerance) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(a[c] - b[c]) > tolerance) return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: png_colours IMAGE.png BACKGROUND_HEX [COLOUR_HEX...]\n");
    return 2;
  }
  const cv::Mat image = cv::imread(argv[1], cv::IMREAD_COLOR);
  if (image.empty()) {
    std::fprintf(stderr, "png_colours: cannot read %s\n", argv[1]);
    return 1;
  }
  const cv::Vec3b background = bgrOf(argv[2]);
  long non_background = 0;
  std::vector<long> counts(static_cast<size_t>(argc - 3), 0);
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
      if (!near(p, background, 24)) ++non_background;
      for (int i = 3; i < argc; ++i)
        if (near(p, bgrOf(argv[i]), 40)) ++counts[static_cast<size_t>(i - 3)];
    }
  std::printf("size %dx%d non_background %ld", image.cols, image.rows, non_background);
  for (int i = 3; i < argc; ++i) std::printf(" %s %ld", argv[i], counts[static_cast<size_t>(i - 3)]);
  std::printf("\n");
  return 0;
}
