#include "rgbdmap/ba/ba_config_table.hpp"

namespace rgbdmap {

const ConfigTable<BaSolveConfig>& baSolveConfigTable() {
  using C = BaSolveConfig;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .addChoice(
              "solver", &C::solver, {{BaSolver::kSchur, "schur"}, {BaSolver::kCeres, "ceres"}},
              "(schur: the own Levenberg-Marquardt with fixed-size blocks, 3x faster; ceres: the reference, "
              "same residuals and minimum)")
          .add("pixel_sigma", &C::pixel_sigma, R::closed(0.05, 100.0), "keypoint sigma at octave 0 (px)")
          .add("scale_factor", &C::scale_factor, R::closed(1.0, 4.0),
               "ORB pyramid scale: the keypoint sigma grows by this per octave")
          .add(
              "inverse_depth_sigma", &C::inverse_depth_sigma, R::closed(1e-5, 10.0),
              "sigma of 1/depth (1/m): 0.025 is 2.5 cm at 1 m, 10 cm at 2 m (a Kinect-class sensor's noise "
              "grows with depth squared; its registration to colour adds more)")
          .add("use_depth", &C::use_depth, "the inverse-depth residual where a keypoint has depth")
          .add("rolling_shutter", &C::rolling_shutter,
               "estimate each keyframe's rotation during the image readout (rolling-shutter cameras; a "
               "global shutter gives ~0)")
          .add("rolling_shutter_sigma_rad", &C::rolling_shutter_sigma_rad, R::closed(1e-6, 10.0),
               "prior sigma of that rotation (rad) around its centre: the robot camera's readout_s times "
               "the camera's angular velocity from the odometry (0 for a global shutter)")
          .add("chi2_2dof", &C::chi2_2dof, R::closed(0.1, 1e4),
               "Huber threshold and outlier test of a 2-row observation (whitened chi2; 5.991 = 95 %)")
          .add("chi2_3dof", &C::chi2_3dof, R::closed(0.1, 1e4),
               "the same for an observation with depth (7.815 = 95 %)")
          .add("first_iterations", &C::first_iterations, R::closed(1, 1000),
               "Levenberg-Marquardt iterations before the outlier test")
          .add("second_iterations", &C::second_iterations, R::closed(0, 1000),
               "iterations after the outliers left (0: no second solve)")
          .add("max_time_s", &C::max_time_s, R::closed(0.0, 3600.0),
               "wall-clock limit of each solve, 0 = none (a limit makes the map depend on the machine's load)")
          .add("iterative_min_frames", &C::iterative_min_frames, R::closed(1, 100000000),
               "the own solver takes conjugate gradients on the implicit reduced camera system (no matrix, "
               "no factor) from this many free keyframes, a sparse Cholesky below")
          .add("iterative_max_steps", &C::iterative_max_steps, R::closed(1, 100000),
               "conjugate-gradient steps per Levenberg-Marquardt iteration")
          .add("iterative_tolerance", &C::iterative_tolerance, R::closed(1e-12, 0.5),
               "conjugate gradients stop at this residual, relative to the right-hand side")
          .add("num_threads", &C::num_threads, R::closed(1, 256), "Ceres threads (the own solver uses one)");
  return table;
}

const ConfigTable<LandmarkMapConfig>& landmarkMapConfigTable() {
  using C = LandmarkMapConfig;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .nest("", &C::solve, baSolveConfigTable())
          .add("local_window", &C::local_window, R::closed(1, 1000),
               "keyframes a local BA moves: the new one and its most covisible")
          .add("local_fixed_max", &C::local_fixed_max, R::closed(0, 10000),
               "other observers of the window's landmarks held fixed in a local BA (most shared first)")
          .add("min_covisibility", &C::min_covisibility, R::closed(1, 10000),
               "landmarks two keyframes share to be covisible")
          .add("projection_keyframes", &C::projection_keyframes, R::closed(0, 1000),
               "covisible keyframes whose landmarks are matched by projection into a new keyframe")
          .add("projection_radius_px", &C::projection_radius_px, R::closed(0.5, 200.0),
               "search radius around a projected landmark at octave 0 (px)")
          .add("projection_max_distance", &C::projection_max_distance, R::closed(0, 256),
               "Hamming distance accepted when matching by projection")
          .add("projection_ratio", &C::projection_ratio, R::closed(0.1, 1.0),
               "best vs second-best descriptor distance within the radius")
          .add("projection_depth_chi2", &C::projection_depth_chi2, R::closed(0.1, 1e4),
               "a keypoint with depth must agree with the projected depth within this whitened chi2")
          .add("global_max_iterations", &C::global_max_iterations, R::closed(0, 1000),
               "iterations of a global BA after its outlier test")
          .add("global_max_time_s", &C::global_max_time_s, R::closed(0.0, 3600.0),
               "wall-clock limit of each of a global BA's two solves, 0 = none (the iterations bound it)")
          .add("global_min_observations", &C::global_min_observations, R::closed(2, 1000),
               "landmarks with fewer observations stay out of a global BA")
          .add("global_rolling_shutter", &C::global_rolling_shutter,
               "a global BA estimates the rolling-shutter rotations too (false: it keeps the local BAs')")
          .add("global_max_observations", &C::global_max_observations, R::closed(0, 100000000),
               "a global BA takes the longest tracks up to this many observations (0: all)")
          .add("global_max_track", &C::global_max_track, R::closed(0, 100000),
               "a global BA takes at most this many observations of a landmark, spread over its observers "
               "(0: all; the cost grows with the square of a track's length)")
          .add("min_frame_observations", &C::min_frame_observations, R::closed(0, 100000),
               "a keyframe with fewer observations in an adjustment is held there (too weakly constrained)")
          .add("part_link_landmarks", &C::part_link_landmarks, R::closed(0, 100000),
               "keyframes sharing this many of an adjustment's landmarks are one part of it; a part no held "
               "keyframe observes keeps its placement as a whole (0: no such correction)");
  return table;
}

std::string LandmarkMapConfig::validate() const {
  return joinProblems(landmarkMapConfigTable().problems(*this));
}

}  // namespace rgbdmap
