# The ROS 2 MCAP reader and CDR decoders (ros/bag/mcap_reader.h, cdr_messages.h). The
# reader's bags come from an independent writer, tests/ros/mcap_writer/write_bag.mjs (npm's
# @mcap/core and @foxglove/rosmsg2-serialization, installed by scripts/deps.sh from its
# package-lock.json), run with node from the source dir: without node the tests that need
# it are skipped (GTEST_SKIP); without its packages they fail.
find_package(OpenCV REQUIRED COMPONENTS core imgcodecs imgproc)
find_package(nlohmann_json REQUIRED CONFIG)
find_package(Eigen3 REQUIRED NO_MODULE)
find_program(SKIMAP_MCAP_NODE node)
if(NOT SKIMAP_MCAP_NODE)
  set(SKIMAP_MCAP_NODE "")
endif()
skimap_add_test(mcap_reader_test SHORT_TESTS
  SOURCES mcap_reader_test.cc
  LIBS skimap_bag opencv_core opencv_imgcodecs opencv_imgproc nlohmann_json::nlohmann_json
    Eigen3::Eigen
  LABELS unit)
target_compile_definitions(mcap_reader_test PRIVATE
  SKIMAP_NODE="${SKIMAP_MCAP_NODE}"
  SKIMAP_YCBV_SCENE="${PROJECT_SOURCE_DIR}/../shared/data/ycbv-0000/test/000000")
skimap_add_test(cdr_messages_test SHORT_TESTS
  SOURCES cdr_messages_test.cc
  LIBS skimap_bag LABELS unit)
# ROS 1's generated message headers use std::allocator<void>::rebind, which C++20 removed.
set_target_properties(mcap_reader_test cdr_messages_test PROPERTIES CXX_STANDARD 17)
