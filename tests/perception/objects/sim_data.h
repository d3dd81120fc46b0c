// The sim `mini` objects for the pipeline tests, generated at test time (once per build
// tree: the first test process renders them under a file lock, later ones reuse them).
#ifndef TESTS_PERCEPTION_OBJECTS_SIM_DATA_H_
#define TESTS_PERCEPTION_OBJECTS_SIM_DATA_H_

#include <string>

namespace skimap::objects::testing {

// Frames per training orbit (2 orbits per object in `mini`); every 4th is held out.
inline constexpr int kTrainFrames = 12;
inline constexpr int kHoldout = 4;
inline bool TrainView(int, int frame_id) { return frame_id % kHoldout != kHoldout - 1; }
inline bool HeldOutView(int, int frame_id) { return frame_id % kHoldout == kHoldout - 1; }

// Root of the generated dataset (train/ only); fails the test on error.
std::string MiniDataset();

// A fresh empty temporary directory for this test.
std::string TempDir();

}  // namespace skimap::objects::testing

#endif  // TESTS_PERCEPTION_OBJECTS_SIM_DATA_H_
