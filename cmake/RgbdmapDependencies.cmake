# Every third-party dependency is found here, once (Debian 12 packages, installed by deploy/install_deps.sh).
find_package(Threads REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs features2d calib3d)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)  # header-only; the programs' JSON outputs (common/json_output)
find_package(zstd REQUIRED)
find_package(ZLIB REQUIRED)  # crc32 for the image blob and the map store's records
find_package(JPEG REQUIRED)  # libjpeg-turbo, the same library OpenCV's imgcodecs links
find_package(OpenSSL REQUIRED)  # HMAC-SHA256 of the message envelope
find_package(octomap REQUIRED)
find_package(Ceres REQUIRED)
find_package(CycloneDDS REQUIRED)
# civetweb (libcivetweb-dev): HTTP + WebSocket server of rgbdmap-viewer. Debian's civetweb-config.cmake names
# a civetweb program the -dev package does not ship, so the library is found directly.
find_path(CIVETWEB_INCLUDE_DIR civetweb.h REQUIRED)
find_library(CIVETWEB_LIBRARY civetweb REQUIRED)
add_library(civetweb::civetweb UNKNOWN IMPORTED)
set_target_properties(civetweb::civetweb PROPERTIES IMPORTED_LOCATION "${CIVETWEB_LIBRARY}"
                                                    INTERFACE_INCLUDE_DIRECTORIES "${CIVETWEB_INCLUDE_DIR}")
find_program(LCM_GEN lcm-gen REQUIRED)
find_path(LCM_INCLUDE_DIR lcm/lcm.h REQUIRED)
find_library(LCM_LIBRARY lcm REQUIRED)
if(RGBDMAP_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()
if(RGBDMAP_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
# Frame sources (client/source). ROS 1 bags through librosbag-storage-dev: its pkg-config file
# requires pluginlib.pc, which Debian does not ship, so headers and libraries are located directly (bag.h
# includes pluginlib, class_loader and the ROS 2 utility headers these need, each in its own folder).
find_path(ROSBAG_INCLUDE_DIR rosbag/bag.h REQUIRED)
set(ROSBAG_HEADER_DIRS ${ROSBAG_INCLUDE_DIR})
foreach(header pluginlib/class_loader.hpp class_loader/class_loader.hpp rcpputils/shared_library.hpp
               rcutils/shared_library.h ament_index_cpp/get_package_prefix.hpp)
  string(REGEX REPLACE "/.*" "" folder ${header})
  find_path(ROSBAG_DEP_${folder}_DIR ${header} PATH_SUFFIXES ${folder} REQUIRED)
  list(APPEND ROSBAG_HEADER_DIRS ${ROSBAG_DEP_${folder}_DIR})
endforeach()
find_library(ROSBAG_STORAGE_LIBRARY rosbag_storage REQUIRED)
find_library(ROSTIME_LIBRARY rostime REQUIRED)
find_library(ROSCPP_SERIALIZATION_LIBRARY roscpp_serialization REQUIRED)
find_library(CONSOLE_BRIDGE_LIBRARY console_bridge REQUIRED)
find_library(ROS_CPP_COMMON_LIBRARY cpp_common REQUIRED)
add_library(rgbdmap_rosbag INTERFACE IMPORTED)
target_include_directories(rgbdmap_rosbag INTERFACE ${ROSBAG_HEADER_DIRS})
target_link_libraries(rgbdmap_rosbag INTERFACE ${ROSBAG_STORAGE_LIBRARY} ${ROSCPP_SERIALIZATION_LIBRARY}
                                               ${ROSTIME_LIBRARY} ${ROS_CPP_COMMON_LIBRARY} ${CONSOLE_BRIDGE_LIBRARY})
# Live OpenNI2 cameras through libopenni2-dev (headers in /usr/include/openni2).
find_path(OPENNI2_INCLUDE_DIR OpenNI.h PATH_SUFFIXES openni2 REQUIRED)
find_library(OPENNI2_LIBRARY OpenNI2 REQUIRED)
add_library(rgbdmap_openni2 INTERFACE IMPORTED)
target_include_directories(rgbdmap_openni2 INTERFACE ${OPENNI2_INCLUDE_DIR})
target_link_libraries(rgbdmap_openni2 INTERFACE ${OPENNI2_LIBRARY})
