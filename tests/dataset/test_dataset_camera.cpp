#include <gtest/gtest.h>

#include "common/common_test_util.hpp"
#include "common/temp_dir.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap {
namespace {

using testing::contains;

TEST(DatasetCamera, AbsentValidAndMalformed) {
  testing::TempDir d;
  auto r = readDatasetCamera(d.dir());
  ASSERT_TRUE(r) << r.error();
  EXPECT_FALSE(r->has_value());

  d.write("camera.yaml",
          "camera: {fx: 525, fy: 525.5, cx: 319.5, cy: 239.5, width: 640, height: 480,\n"
          "         distortion: [0.1, -0.2, 0.001, 0.002, 0.3], depth_scale: 1000, readout_s: 0}\n");
  r = readDatasetCamera(d.dir());
  ASSERT_TRUE(r) << r.error();
  ASSERT_TRUE(r->has_value());
  EXPECT_EQ((*r)->fy, 525.5);
  EXPECT_EQ((*r)->height, 480);
  EXPECT_EQ((*r)->distortion[4], 0.3);
  EXPECT_EQ((*r)->depth_scale, 1000);
  EXPECT_EQ((*r)->readout_s, 0.0) << "a global shutter";
  d.write("camera.yaml", datasetCameraYaml(**r, "written back"));
  auto again = readDatasetCamera(d.dir());
  ASSERT_TRUE(again && again->has_value()) << again.error();
  EXPECT_TRUE(sameIntrinsics(**again, **r));

  d.write("camera.yaml",
          "camera:\n  fx: 525\n  fy: 525\n  cx: 319.5\n  cy: 239.5\n  width: 640\n  height: 480\n");
  r = readDatasetCamera(d.dir());
  ASSERT_TRUE(r) << r.error();
  EXPECT_FALSE((*r)->hasDistortion());
  EXPECT_EQ((*r)->depth_scale, 5000);
  EXPECT_EQ((*r)->readout_s, CameraIntrinsics{}.readout_s) << "unsaid: a rolling shutter like TUM fr1's";

  d.write("camera.yaml",
          "camera:\n  fx: abc\n  fy: 525\n  cx: 319.5\n  cy: 239.5\n  width: 640\n  heigth: 480\n");
  r = readDatasetCamera(d.dir());
  ASSERT_FALSE(r);
  EXPECT_TRUE(contains(r.error(), "camera.yaml:2: camera.fx: 'abc' is not a number")) << r.error();
  EXPECT_TRUE(contains(r.error(), "camera.yaml:7: unknown key camera.heigth")) << r.error();
  EXPECT_TRUE(contains(r.error(), "camera.height is missing")) << r.error();

  d.write("camera.yaml", "camera: {fx: -1, fy: 525, cx: 1, cy: 1, width: 640, height: 480}\n");
  EXPECT_TRUE(contains(readDatasetCamera(d.dir()).error(), "fx = -1 is outside [1, 100000]"));
  d.write("camera.yaml", "camera: {fx: 1, fy: 1, cx: 1, cy: 1, width: 64, height: 48, distortion: [1, 2]}\n");
  EXPECT_TRUE(contains(readDatasetCamera(d.dir()).error(), "list of 5 numbers"));
  d.write("camera.yaml", "camera: {fx: 1, fy: 1, cx: 1, cy: 1, width: 64, height: 48, readout_s: 0.5}\n");
  EXPECT_TRUE(contains(readDatasetCamera(d.dir()).error(), "readout_s = 0.5 is outside [0, 0.1]"));
  d.write("camera.yaml", "camera: [1, 2\n");
  EXPECT_TRUE(contains(readDatasetCamera(d.dir()).error(), "camera.yaml:"));
}

}  // namespace
}  // namespace rgbdmap
