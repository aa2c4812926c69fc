#include "rgbdmap/dataset/dataset_config_table.hpp"

namespace rgbdmap {

const ConfigTable<DatasetOptions>& datasetConfigTable() {
  using D = DatasetOptions;
  using R = ConfigRange;
  static const ConfigTable<D> table =
      ConfigTable<D>()
          .add("max_time_diff", &D::max_time_diff, R::openClosed(0.0, 10.0),
               "colour <-> depth association tolerance (s)")
          .add("depth_scale", &D::depth_scale, R::above(0.0), "depth units per metre (from the camera)")
          .codeOnly()
          .add("expected_width", &D::expected_width, R::atLeast(0), "0 accepts any width")
          .codeOnly()
          .add("expected_height", &D::expected_height, R::atLeast(0), "0 accepts any height")
          .codeOnly();
  return table;
}

}  // namespace rgbdmap
