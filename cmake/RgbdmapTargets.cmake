# The stanzas every folder would otherwise copy: a library with its header folder and its layer, a
# benchmark program, and the check that keeps links pointing down.
#
# Layers (a library links only libraries of a lower layer; the robot's and the server's stacks never link
# each other, what they share lives in a "shared" library below both):
#   0  common                                       shared
#   1  codec, dataset, mcap                         shared
#   2  synth, proto, transport                      shared
#   3  vision                                       shared   | source (frame sources)            robot
#                                                            | server intake (receive side)      server
#   4  client (odometry)                            robot    | loop, graph, ba, store, map,      server
#                                                            |   export
#   5  link (robot side of the protocol)            robot    | backend (the map back-end)        server
#   6                                                        | server model (config, records)    server
#   7                                                        | server workers (threads)          server
#   8                                                        | server ingest                     server
#   9                                                        | server (the mapping service)      server
#  10  cli, viewer (what the programs in apps/ share)   app
#  11  cli_source (--source / --dataset for the programs) app
# Programs (apps/, benchmarks, tests) are executables on top and may link anything.

set_property(GLOBAL PROPERTY RGBDMAP_LIBRARIES "")

# Gives `target` its place in the layers and registers it for rgbdmap_check_layers().
function(rgbdmap_register_layer target)
  cmake_parse_arguments(ARG "" "LAYER;SIDE" "" ${ARGN})
  if(NOT ARG_LAYER MATCHES "^[0-9]+$")
    message(FATAL_ERROR "rgbdmap_register_layer(${target}): LAYER must be a number, got '${ARG_LAYER}'")
  endif()
  if(NOT ARG_SIDE MATCHES "^(shared|robot|server|app)$")
    message(FATAL_ERROR "rgbdmap_register_layer(${target}): SIDE must be shared|robot|server|app")
  endif()
  set_target_properties(${target} PROPERTIES RGBDMAP_LAYER ${ARG_LAYER} RGBDMAP_SIDE ${ARG_SIDE})
  set_property(GLOBAL APPEND PROPERTY RGBDMAP_LIBRARIES ${target})
endfunction()

# rgbdmap_add_library(NAME LAYER n SIDE shared|robot|server|app SOURCES ... [PUBLIC libs...] [PRIVATE libs...])
# A static library whose public headers are in <folder>/include/rgbdmap/<short name>/ and whose private
# headers are in <folder>/src/.
function(rgbdmap_add_library name)
  cmake_parse_arguments(ARG "" "LAYER;SIDE" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                                      PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
  rgbdmap_register_layer(${name} LAYER ${ARG_LAYER} SIDE ${ARG_SIDE})
  rgbdmap_target_defaults(${name})
endfunction()

# rgbdmap_add_benchmark(NAME SOURCES ... LIBS ... [DEFINITIONS ...]): a program in bin/ that prints numbers
# (Google Benchmark is linked; a benchmark with its own main() simply does not use it). Knows where the
# real recordings are (RGBDMAP_SHARED_DATA_DIR) and the source tree (RGBDMAP_SOURCE_DIR).
function(rgbdmap_add_benchmark name)
  if(NOT RGBDMAP_BUILD_BENCHMARKS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS;DEFINITIONS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} benchmark::benchmark)
  target_compile_definitions(${name} PRIVATE RGBDMAP_SHARED_DATA_DIR="${RGBDMAP_SHARED_DATA_DIR}"
                                             RGBDMAP_SOURCE_DIR="${PROJECT_SOURCE_DIR}" ${ARG_DEFINITIONS})
  rgbdmap_target_defaults(${name})
endfunction()

# Fails the configuration when a registered library links one of the same or a higher layer, or when the
# robot's stack and the server's stack link each other. Called once, after every folder is added.
function(rgbdmap_check_layers)
  get_property(libs GLOBAL PROPERTY RGBDMAP_LIBRARIES)
  set(problems "")
  foreach(lib IN LISTS libs)
    get_target_property(layer ${lib} RGBDMAP_LAYER)
    get_target_property(side ${lib} RGBDMAP_SIDE)
    get_target_property(type ${lib} TYPE)
    set(deps "")
    if(NOT type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(deps ${lib} LINK_LIBRARIES)
    endif()
    get_target_property(interface_deps ${lib} INTERFACE_LINK_LIBRARIES)
    foreach(dep IN LISTS deps interface_deps)
      string(REGEX REPLACE "^\\$<LINK_ONLY:(.*)>$" "\\1" dep "${dep}")
      if(NOT TARGET "${dep}")
        continue()
      endif()
      get_target_property(dep_layer ${dep} RGBDMAP_LAYER)
      if(NOT dep_layer MATCHES "^[0-9]+$")
        continue()  # a third-party target
      endif()
      get_target_property(dep_side ${dep} RGBDMAP_SIDE)
      if(NOT dep_layer LESS layer)
        list(APPEND problems "${lib} (layer ${layer}) links ${dep} (layer ${dep_layer}): links must point down")
      endif()
      if((side STREQUAL "robot" AND dep_side STREQUAL "server") OR (side STREQUAL "server" AND dep_side STREQUAL "robot"))
        list(APPEND problems "${lib} (${side}) links ${dep} (${dep_side}): share code through a library below both")
      endif()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES problems)
  if(problems)
    list(JOIN problems "\n  " text)
    message(FATAL_ERROR "rgbdmap layer check failed (cmake/RgbdmapTargets.cmake):\n  ${text}")
  endif()
endfunction()
