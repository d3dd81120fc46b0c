// The precompiled header of the test programs in clang builds (tests/CMakeLists.txt,
// SKIMAP_TEST_PCH): the third-party headers most test programs parse, directly or through
// the libraries' headers. Parsing them is about half of compiling a test batch at -O0
// under ASan; a test program gets them from one header compiled once per flavour of its
// flags instead. Only headers that do not change with our sources belong here: a change
// to one of ours would recompile every test program.
#pragma once

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/message.h"
