// The object that builds tests/common/precompiled.h's precompiled header (tests/CMakeLists.txt,
// SKIMAP_TEST_PCH; CMake includes the header); it holds no code.
