#pragma once
// Config table (config_table.hpp) of the dataset reader: keys, ranges, meanings.
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap {

/// max_time_diff (the `dataset:` section); depth_scale and the expected image size are set by code.
const ConfigTable<DatasetOptions>& datasetConfigTable();

}  // namespace rgbdmap
