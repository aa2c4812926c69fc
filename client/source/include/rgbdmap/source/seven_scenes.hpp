#pragma once
// Microsoft 7-Scenes (Shotton et al., CVPR 2013) sequence folders: `frame-NNNNNN.color.png` (colour),
// `frame-NNNNNN.depth.png` (16-bit millimetres of the Kinect's depth camera, 65535 = no measurement) and
// `frame-NNNNNN.pose.txt` (a 4x4 camera-to-world matrix from KinectFusion, the depth camera's pose),
// numbered from 0 at 30 frames/s.
//
// The depth is not registered to the colour: the two cameras are a Kinect v1's infrared and colour cameras
// (focal lengths 585 and 525 px, 2.6 cm apart). The source registers each depth image to the colour camera
// (registerDepth), yields the colour camera's intrinsics, and gives the ground truth of the colour camera
// (T_world_colour = T_world_depth * T_colour_depth^-1), so that a trajectory and the ground truth name the
// same camera.
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {

/// The 7-Scenes calibration: the dataset's depth camera (focal 585 px, principal point at the image's
/// centre), the colour camera of its Kinect v1 (focal 525 px) and the depth -> colour transform of a Kinect
/// v1 (the LIRIS activities dataset's calibration, the one 7-Scenes' relocalisation literature uses).
struct SevenScenesCalibration {
  CameraIntrinsics depth_camera;
  CameraIntrinsics colour_camera;
  SE3 T_colour_depth = SE3::Identity();  ///< a point in the depth camera's frame -> the colour camera's
  static SevenScenesCalibration standard();
};

/// Reprojects `depth` (CV_16UC1 in `from.depth_scale` units per metre; 0 and `invalid` mean no measurement)
/// from the camera `from` into the camera `to` (ideal pinholes; distortion is not modelled) placed at
/// T_to_from. Each pixel lands on its nearest pixel of `to`'s image; the nearest surface wins. The result is
/// CV_16UC1 of to.width x to.height in `to.depth_scale` units, 0 where nothing landed.
cv::Mat registerDepth(const cv::Mat& depth, const CameraIntrinsics& from, const CameraIntrinsics& to,
                      const SE3& T_to_from, uint16_t invalid = 0);

/// True when `dir` holds a 7-Scenes sequence (its first frame, frame-000000.color.png) and no rgb.txt.
bool isSevenScenesFolder(const std::string& dir);

/// Parses a frame-NNNNNN.pose.txt: 16 finite numbers, a rigid transform (orthonormal rotation within 1e-3,
/// last row 0 0 0 1); the reason otherwise.
Result<SE3> parseSevenScenesPose(const std::string& text, const std::string& source_name);

}  // namespace rgbdmap
