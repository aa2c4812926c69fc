#pragma once
// Read-only data files the programs ship (the viewer's web page, the DDS configurations), found wherever the
// programs are installed or moved. A file `share/rgbdmap/<relative>` is looked for, in this order:
//   1. $RGBDMAP_DATA_DIR/<relative>             (an explicit folder, e.g. a copied tree)
//   2. <folder of the executable>/../share/rgbdmap/<relative>
//                                                (an install under any prefix, and the build tree, which
//                                                 stages the files in build/share/rgbdmap)
//   3. <configured install prefix>/share/rgbdmap/<relative>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap {

/// The folders searched for data files, in order (see above); `installed_data_dir` is item 3.
std::vector<std::string> dataSearchPath(const std::string& installed_data_dir);

/// The first existing `<folder>/<relative>` of dataSearchPath(); on failure the reason names every place
/// looked in and how to point the program at the files (RGBDMAP_DATA_DIR).
Result<std::string> findDataFile(const std::string& relative, const std::string& installed_data_dir);

}  // namespace rgbdmap
