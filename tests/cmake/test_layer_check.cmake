# Configures tests/cmake/layer_fixture once per kind of link and checks that the layer check accepts links
# that point down and fails the configuration, naming the offending link, for every other kind.
# cmake -DSOURCE_DIR=<project> -DWORK_DIR=<scratch> -P test_layer_check.cmake
set(expect_none "ok")
set(expect_down "ok")
set(expect_up "shared_low \\(layer 1\\) links robot_mid \\(layer 3\\)")
set(expect_same "server_top \\(layer 3\\) links server_mid \\(layer 3\\)")
set(expect_across "server_top \\(server\\) links robot_mid \\(robot\\)")
set(failures "")
foreach(link none down up same across)
  file(REMOVE_RECURSE ${WORK_DIR}/${link})
  execute_process(
    COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/cmake/layer_fixture -B ${WORK_DIR}/${link}
            -DRGBDMAP_CMAKE_DIR=${SOURCE_DIR}/cmake -DLINK=${link}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect_${link} STREQUAL "ok")
    if(NOT rc EQUAL 0)
      list(APPEND failures "${link}: expected success, got ${rc}: ${err}")
    endif()
  elseif(rc EQUAL 0)
    list(APPEND failures "${link}: configured although the link is not allowed")
  elseif(NOT err MATCHES "${expect_${link}}")
    list(APPEND failures "${link}: failed without naming the link: ${err}")
  endif()
endforeach()
if(failures)
  message(FATAL_ERROR "layer check test failed:\n${failures}")
endif()
message(STATUS "layer check: down accepted; up, same-layer and robot/server links rejected")
