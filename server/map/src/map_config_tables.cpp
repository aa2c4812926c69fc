#include "rgbdmap/map/map_config_tables.hpp"

namespace rgbdmap {

using R = ConfigRange;

const ConfigTable<OccupancyMapConfig>& occupancyMapConfigTable() {
  using C = OccupancyMapConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("resolution_m", &C::resolution_m, R::closed(0.005, 1.0), "octree leaf size")
          .add("max_range_m", &C::max_range_m, R::closed(0.1, 50.0),
               "depth beyond this clears free space up to here but is not inserted as occupied "
               "(must be above min_range_m)")
          .add("min_range_m", &C::min_range_m, R::closed(0.0, 10.0), "closer depth is dropped")
          .add("prob_hit", &C::prob_hit, R::open(0.5, 1.0), "OctoMap sensor model")
          .add("prob_miss", &C::prob_miss, R::open(0.0, 0.5), "")
          .add("clamp_min", &C::clamp_min, R::open(0.0, 0.5), "")
          .add("clamp_max", &C::clamp_max, R::open(0.5, 1.0), "")
          .add("rebuild_translation_m", &C::rebuild_translation_m, R::closed(0.0, 10.0),
               "an optimisation moving a keyframe more than this (or rotating it more than "
               "rebuild_rotation_rad) rebuilds its map in the background from the kept keyframe clouds")
          .add("rebuild_rotation_rad", &C::rebuild_rotation_rad, R::closed(0.0, 3.15), "")
          .add("partial_rebuild_max_fraction", &C::partial_rebuild_max_fraction, R::closed(0.0, 1.0),
               "when at most this fraction of a map's keyframes moved, a rebuild recomputes only the "
               "octree cells their rays touch (same result); 0: always the whole tree")
          .add("partial_rebuild_held_mb", &C::partial_rebuild_held_mb, R::closed(0, 65536),
               "MB of moved keyframes' ray casts a partial rebuild keeps between its two passes; beyond, "
               "they are cast again (CPU instead of memory)")
          .add("pixel_stride", &C::pixel_stride, R::closed(0, 64),
               "depth pixel sampling step; 0: automatic (3 at 0.05 m, 1 at 0.02 m for fx 517)")
          .add("cloud_voxel_fraction", &C::cloud_voxel_fraction, R::closed(0.0, 1.0),
               "kept cloud reduced to one point per cube of this fraction of resolution_m")
          .add("keep_colors", &C::keep_colors, "keep colours for map.ply")
          .add("clouds_in_memory", &C::clouds_in_memory, R::closed(0, 1e8),
               "the newest this many kept keyframe clouds stay in RAM, older ones go to an anonymous file in "
               "server.map_dir and are read back for rebuilds and exports (0: all in RAM)");
  return table;
}

const ConfigTable<SliceConfig>& sliceConfigTable() {
  using C = SliceConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("size_m", &C::size_m, R::closed(0.1, 100.0),
               "side of the square grid, centred on the robot (at most kMaxGridSide cells)")
          .add("resolution_m", &C::resolution_m, R::closed(0.005, 1.0), "cell side")
          .add("z_min_m", &C::z_min_m, R::closed(-10.0, 10.0),
               "height band relative to the camera (up = z of the z-up map frame; the global 2-D map uses "
               "the same band around the median camera height of its keyframes)")
          .add("z_max_m", &C::z_max_m, R::closed(-10.0, 10.0), "")
          .add("occupied_threshold", &C::occupied_threshold, R::open(0.0, 1.0),
               "leaf occupancy probability above which a cell is occupied");
  return table;
}

}  // namespace rgbdmap
