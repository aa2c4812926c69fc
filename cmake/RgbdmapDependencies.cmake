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
