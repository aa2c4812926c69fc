// Test helper: a copy of a TUM-layout dataset with its colour images re-encoded as JPEG of a given quality
// (as a compressed image stream or an MJPEG camera delivers them). Depth images are linked, not copied;
// rgb.txt names the new files; every other text file is copied as it is. Files are written atomically.
// Usage: make_jpeg_dataset SOURCE_DIR OUTPUT_DIR QUALITY [FRAMES]
//   FRAMES: only the first FRAMES colour images (default all). Exit 0 on success, 1 on a read or write
//   failure, 2 on usage.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/common/atomic_file.hpp"

namespace fs = std::filesystem;

namespace {

int fail(const std::string& what) {
  std::fprintf(stderr, "make_jpeg_dataset: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || argc > 5) {
    std::fprintf(stderr, "usage: make_jpeg_dataset SOURCE_DIR OUTPUT_DIR QUALITY [FRAMES]\n");
    return 2;
  }
  const fs::path src = argv[1], out = argv[2];
  const int quality = std::atoi(argv[3]);
  const long frames = argc == 5 ? std::atol(argv[4]) : -1;
  if (quality < 1 || quality > 100) {
    std::fprintf(stderr, "make_jpeg_dataset: QUALITY must be in [1, 100]\n");
    return 2;
  }
  std::error_code ec;
  fs::create_directories(out / "rgb", ec);
  if (ec) return fail("cannot create " + (out / "rgb").string() + ": " + ec.message());
  for (const auto& entry : fs::directory_iterator(src)) {
    const fs::path name = entry.path().filename();
    if (entry.is_regular_file() && name.extension() == ".txt" && name != "rgb.txt")
      fs::copy_file(entry.path(), out / name, fs::copy_options::overwrite_existing, ec);
    else if (name == "depth")
      fs::create_directory_symlink(fs::absolute(entry.path()), out / "depth", ec);
    if (ec) return fail("cannot copy " + entry.path().string() + ": " + ec.message());
  }
  std::ifstream in(src / "rgb.txt");
  if (!in) return fail("cannot read " + (src / "rgb.txt").string());
  std::ostringstream list;
  std::string line;
  long written = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') {
      list << line << "\n";
      continue;
    }
    if (frames >= 0 && written >= frames) break;
    std::istringstream fields(line);
    std::string stamp, file;
    if (!(fields >> stamp >> file)) return fail("malformed line in rgb.txt: " + line);
    const cv::Mat image = cv::imread((src / file).string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) return fail("cannot read " + (src / file).string());
    const std::string name = "rgb/" + fs::path(file).stem().string() + ".jpg";
    std::vector<uchar> jpeg;
    if (!cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality}))
      return fail("cannot encode " + (src / file).string());
    if (const rgbdmap::Status s = rgbdmap::writeFileAtomic(
            (out / name).string(), std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
        !s)
      return fail(s.error());
    list << stamp << " " << name << "\n";
    ++written;
  }
  if (const rgbdmap::Status s = rgbdmap::writeFileAtomic((out / "rgb.txt").string(), list.str()); !s)
    return fail(s.error());
  std::printf("%ld colour images re-encoded as JPEG %d in %s\n", written, quality, out.c_str());
  return 0;
}
