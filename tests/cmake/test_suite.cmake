# rgbdmap_add_test_suite(NAME [TEST_PREFIX p] SOURCES ... LIBS ...): one library's GoogleTest executable,
# registered with CTest. A case's tier is written next to it in its source (tests/test_tier.hpp):
#   RGBDMAP_TEST_TIER("Suite.*", "e2e");  "e2e sanitize";  "accuracy";  "elsewhere"
# and read here at configure time (a source's change configures again). Labels:
#   unit      every case no tier line names; also run under the sanitizers (sanitize)
#   e2e       end to end; "e2e sanitize" ones also run under the sanitizers
#   accuracy  accuracy bounds on whole sequences (Release only)
#   elsewhere not registered here: another CTest test runs them (e.g. the network tests in the namespace)
# Per-tier labels through gtest_discover_tests' TEST_FILTER (one discovery per tier) rather than separate
# executables: no extra links, and one file may hold suites of several tiers. A discovered test carries one
# label only (its PROPERTIES cannot pass a list): each discovery keeps its list of test names (TEST_LIST),
# and a CTest include file read after the discovered tests sets LABELS "unit;sanitize" on every unit test
# and "e2e;sanitize" on the sanitize ones. No GoogleTest case may be slow (20 s in Release): make it faster.
include(GoogleTest)

# Reads the RGBDMAP_TEST_TIER lines of `sources` into <prefix>_E2E, _SANITIZE, _ACCURACY, _ELSEWHERE.
function(rgbdmap_read_test_tiers prefix)
  set(tiers E2E SANITIZE ACCURACY ELSEWHERE)
  foreach(tier IN LISTS tiers)
    set(${tier} "")
  endforeach()
  foreach(source IN LISTS ARGN)
    get_filename_component(path ${source} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${path})
    file(READ ${path} text)
    string(REGEX MATCHALL "RGBDMAP_TEST_TIER\\([^)]*\\)" lines "${text}")
    foreach(line IN LISTS lines)
      if(NOT line MATCHES "\\([ \t\r\n]*\"([^\"]+)\"[ \t\r\n]*,[ \t\r\n]*\"([^\"]+)\"[ \t\r\n]*\\)")
        message(FATAL_ERROR "${source}: malformed tier line: ${line}")
      endif()
      set(pattern ${CMAKE_MATCH_1})
      string(REPLACE " " ";" labels "${CMAKE_MATCH_2}")
      if(labels STREQUAL "e2e")
        list(APPEND E2E ${pattern})
      elseif(labels STREQUAL "e2e;sanitize")
        list(APPEND E2E ${pattern})
        list(APPEND SANITIZE ${pattern})
      elseif(labels STREQUAL "accuracy")
        list(APPEND ACCURACY ${pattern})
      elseif(labels STREQUAL "elsewhere")
        list(APPEND ELSEWHERE ${pattern})
      else()
        message(FATAL_ERROR "${source}: tier of ${pattern} is \"${CMAKE_MATCH_2}\"; "
                            "one of: e2e, e2e sanitize, accuracy, elsewhere")
      endif()
    endforeach()
  endforeach()
  foreach(tier IN LISTS tiers)
    set(${prefix}_${tier} ${${tier}} PARENT_SCOPE)
  endforeach()
endfunction()

# The sanitizer tree (RGBDMAP_SANITIZE) runs the sanitize tier per executable, not per case: a process under
# ASan takes ~0.5 s to start (shadow memory, the libraries' static constructors): one process per case (~500)
# would double the sanitizer pass. Its unit cases run in shards (GoogleTest's own sharding, CTest tests
# `<executable>.unit.<i>of<n>`), its "e2e sanitize" cases as `<executable>.e2e`; a failed one names the case
# in its output. Labels "unit;sanitize" and "e2e;sanitize".
# A fresh tree has no timings of an earlier run, so `ctest -j` starts tests in the order of their COST and
# then of their declaration. The seconds each executable's runs took on a fresh 2-core root (unit, e2e) are
# their COST, so the long ones start first and none of them is left alone at the end; an executable over
# 40 s of unit cases gets one shard per 20 s. The rest: 2 shards, COST 10.
set(RGBDMAP_SANITIZE_SECONDS test_occupancy:77:0 test_workers:48:8 test_map_server:2:41 test_pose_graph:32:0
    test_ba:29:0 test_synth:29:0 test_source:26:0 test_robot_link:21:3 test_transport:18:0 test_map_store:15:0
    test_client:2:7 test_loop_closure:3:6)
function(rgbdmap_add_sanitized_runs name unit_filter sanitize_patterns elsewhere)
  set(unit_seconds 10)
  set(e2e_seconds 10)
  foreach(entry IN LISTS RGBDMAP_SANITIZE_SECONDS)
    string(REPLACE ":" ";" entry "${entry}")
    list(GET entry 0 suite)
    if(suite STREQUAL name)
      list(GET entry 1 unit_seconds)
      list(GET entry 2 e2e_seconds)
    endif()
  endforeach()
  set(shards 2)
  if(unit_seconds GREATER 40)
    math(EXPR shards "(${unit_seconds} + 19) / 20")
  endif()
  foreach(i RANGE 1 ${shards})
    math(EXPR index "${i} - 1")
    math(EXPR cost "${unit_seconds} / ${shards} + 1")
    add_test(NAME ${name}.unit.${i}of${shards}
             COMMAND ${name} --gtest_filter=${unit_filter} --gtest_also_run_disabled_tests)
    set_tests_properties(${name}.unit.${i}of${shards} PROPERTIES LABELS "unit;sanitize" TIMEOUT 900 COST ${cost}
                         ENVIRONMENT "GTEST_TOTAL_SHARDS=${shards};GTEST_SHARD_INDEX=${index}")
  endforeach()
  if(sanitize_patterns)
    list(JOIN sanitize_patterns ":" sanitize)
    add_test(NAME ${name}.e2e COMMAND ${name} --gtest_filter=${sanitize}-${elsewhere}
                                           --gtest_also_run_disabled_tests)
    set_tests_properties(${name}.e2e PROPERTIES LABELS "e2e;sanitize" TIMEOUT 900 COST ${e2e_seconds})
  endif()
endfunction()

function(rgbdmap_add_test_suite name)
  cmake_parse_arguments(ARG "" "TEST_PREFIX" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE RGBDMAP_SHARED_DATA_DIR="${RGBDMAP_SHARED_DATA_DIR}"
                                           RGBDMAP_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_include_directories(${name} PRIVATE ${RGBDMAP_TESTS_DIR})
  rgbdmap_target_defaults(${name})
  if(RGBDMAP_SANITIZE)
    # The tests' own code at -O0 (after the defaults' -O1): it compiles in ~40 % of the time and runs little
    # of the work, which stays in the libraries at -O1 (deploy/test.sh: the sanitizer tree's build time).
    # Without UBSan's pointer checks, as the numeric libraries (cmake/RgbdmapWarnings.cmake): ASan and
    # UBSan's arithmetic checks stay, and the unity file of test_map_server compiles in 21 s instead of 31 s.
    target_compile_options(${name} PRIVATE -O0 -fno-sanitize=pointer-overflow,alignment,null,object-size,vptr)
  endif()
  add_dependencies(rgbdmap_test_executables ${name})
  rgbdmap_read_test_tiers(tier ${ARG_SOURCES})
  set(discover TEST_PREFIX "${ARG_TEST_PREFIX}" DISCOVERY_TIMEOUT 60)
  list(JOIN tier_ELSEWHERE ":" elsewhere)
  set(not_unit ${tier_E2E} ${tier_ACCURACY} ${tier_ELSEWHERE})
  list(JOIN not_unit ":" not_unit)
  if(RGBDMAP_SANITIZE)
    rgbdmap_add_sanitized_runs(${name} "*-${not_unit}" "${tier_SANITIZE}" "${elsewhere}")
    return()
  endif()
  gtest_discover_tests(${name} ${discover} TEST_FILTER "*-${not_unit}" TEST_LIST ${name}_unit_tests
                       PROPERTIES PROCESSORS ${RGBDMAP_TEST_PROCESSORS} TIMEOUT 600 LABELS unit)
  set(sanitize_lists ${name}_unit_tests)
  if(tier_E2E)
    list(JOIN tier_E2E ":" e2e)
    set(not_e2e ${tier_ELSEWHERE} ${tier_ACCURACY} ${tier_SANITIZE})
    list(JOIN not_e2e ":" not_e2e)
    # COST: `ctest -j` starts the long ones first, also in a fresh tree without timings of an earlier run.
    gtest_discover_tests(${name} ${discover} TEST_FILTER "${e2e}-${not_e2e}" TEST_LIST ${name}_e2e_tests
                         PROPERTIES PROCESSORS ${RGBDMAP_TEST_PROCESSORS} TIMEOUT 600 LABELS e2e COST 100)
  endif()
  if(tier_SANITIZE)  # e2e tests run under the sanitizers too
    list(JOIN tier_SANITIZE ":" sanitize)
    gtest_discover_tests(${name} ${discover} TEST_FILTER "${sanitize}-${elsewhere}"
                         TEST_LIST ${name}_sanitize_tests PROPERTIES PROCESSORS ${RGBDMAP_TEST_PROCESSORS} TIMEOUT 600 LABELS e2e COST 100)
    list(APPEND sanitize_lists ${name}_sanitize_tests)
  endif()
  set(labels_file ${CMAKE_CURRENT_BINARY_DIR}/${name}_sanitize_labels.cmake)
  file(WRITE ${labels_file} "# Generated by tests/cmake/test_suite.cmake: the sanitize label of ${name}'s tests.\n")
  foreach(list IN LISTS sanitize_lists)
    string(REGEX REPLACE ".*_([a-z]+)_tests$" "\\1" tier ${list})
    if(tier STREQUAL "sanitize")
      set(tier e2e)
    endif()
    file(APPEND ${labels_file} "foreach(t IN LISTS ${list})\n"
                               "  set_tests_properties(\"\${t}\" PROPERTIES LABELS \"${tier};sanitize\")\n"
                               "endforeach()\n")
  endforeach()
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${labels_file})
  set(patterns ${tier_E2E} ${tier_ACCURACY} ${tier_ELSEWHERE})
  if(patterns)  # every tier line names a case (a typo would leave the cases it meant in the unit tier)
    list(REMOVE_DUPLICATES patterns)
    add_test(NAME lint.tiers.${name} COMMAND python3 ${RGBDMAP_TESTS_DIR}/cmake/check_tier_patterns.py
                                             $<TARGET_FILE:${name}> ${patterns})
    set_tests_properties(lint.tiers.${name} PROPERTIES LABELS unit TIMEOUT 120)
  endif()
  if(tier_ACCURACY)
    list(JOIN tier_ACCURACY ":" accuracy)
    gtest_discover_tests(${name} ${discover} TEST_FILTER "${accuracy}-${elsewhere}"
                         PROPERTIES PROCESSORS ${RGBDMAP_TEST_PROCESSORS} TIMEOUT 600 LABELS accuracy COST 200)
  endif()
endfunction()
