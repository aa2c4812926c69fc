# One place for compiler warnings and sanitizer flags; every target calls rgbdmap_target_defaults().
function(rgbdmap_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(RGBDMAP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(CMAKE_UNITY_BUILD)
    # A source's anonymous-namespace types used in its own classes are fine; a unity build includes the source
    # into another file, where GCC takes it for a header and warns.
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wno-subobject-linkage>)
  endif()
  if(RGBDMAP_SANITIZE)
    # -O1 -g1 (after the build type's flags): what ASan recommends, line tables for the reports, and a tree
    # that compiles in about half the time of -O2 -g.
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer -O1 -g1)
    # Libraries that orchestrate rather than compute (the server's threads and queues, the viewer, the
    # robot's link, messages, the store, file readers: datasets, MCAP, ROS 2 messages) at -O0: they are a
    # third of the sanitizer tree's compile time and little of its tests' run time, which stays in vision,
    # loop closure, the pose graph, BA and the octree.
    set(orchestration rgbdmap_server rgbdmap_server_ingest rgbdmap_server_intake rgbdmap_server_workers
        rgbdmap_server_model rgbdmap_viewer rgbdmap_robot_link rgbdmap_proto rgbdmap_map_export
        rgbdmap_map_store rgbdmap_transport rgbdmap_source rgbdmap_cli rgbdmap_cli_source rgbdmap_mcap
        rgbdmap_ros2_bridge rgbdmap_ros2_dds rgbdmap_dataset)
    if(target IN_LIST orchestration)
      target_compile_options(${target} PRIVATE -O0)
    endif()
    # The numeric libraries (Eigen expression templates over memory they allocate themselves) without UBSan's
    # pointer checks: ASan already reports their out-of-bounds and null accesses, and those five checks take
    # over half the compile time of Eigen-heavy code (server/ba's unity file: 129 s with them, 62 s without).
    # UBSan's arithmetic checks (signed overflow, shifts, division by zero, bool, enum, bounds of arrays)
    # stay on everywhere, all of its checks on the code that reads messages, files and configuration.
    set(numeric rgbdmap_ba rgbdmap_pose_graph rgbdmap_vision rgbdmap_occupancy rgbdmap_backend
        rgbdmap_loop_closure rgbdmap_synth)
    if(target IN_LIST numeric)
      target_compile_options(${target} PRIVATE -fno-sanitize=pointer-overflow,alignment,null,object-size,vptr)
    endif()
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
    # Under ASan, Eigen allocates its aligned buffers by hand (malloc + offset) unless told that malloc
    # aligns; Debian's libceres.a (linked statically) was built without ASan and frees with plain free().
    # Template functions both instantiate (the sparse Cholesky's, since the bundle adjuster's own solver)
    # are merged by the linker, so one side's allocation met the other's free: "bad-free" in Ceres'
    # EigenSparseCholesky. ASan's malloc returns 16-byte aligned memory on x86-64, as glibc's does.
    target_compile_definitions(${target} PRIVATE EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
endfunction()
