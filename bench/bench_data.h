// Workloads shared by every side-by-side benchmark: the same points go into every structure.
//
//   const Cloud& frame = RoomFrame();       // synthetic noisy 640x480 room frame, world frame
//   const std::vector<Cloud>& real = YcbvFrames();  // 10 real frames (empty if data missing)
//   const Cloud& pts = UniformPoints();     // 1 M uniform points in [0, 4 m)^3, fixed seed
//
// Every cloud is in the world frame (metres, z up). All generators are deterministic
// (fixed seeds), so runs on different days and machines see the same points. Results are
// built on first use and cached for the life of the process.
//
// Thread safety: the accessors use function-local statics (thread-safe initialization);
// the returned references are immutable.
#ifndef SKIMAP_BENCH_BENCH_DATA_H_
#define SKIMAP_BENCH_BENCH_DATA_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace skimap::bench {

struct PointF {
  float x = 0, y = 0, z = 0;
};
using Cloud = std::vector<PointF>;

// Camera-to-world pose: world = R * cam + t, camera axes x right, y down, z forward.
struct CameraPose {
  double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major
  double t[3] = {0, 0, 0};
};

// The synthetic room: an 8 x 9 x 2.8 m box (floor z = 0) with a table and boxes. A camera
// at 1.3 m height looking along `yaw_deg` (0 = +x), pitched `pitch_deg` down, placed at
// (x, y). Walls are 3-5 m away from the default pose.
CameraPose RoomCameraPose(double x, double y, double yaw_deg, double pitch_deg);

// Ray-casts one 640x480 depth frame (fx = fy = 525, principal point at the centre) of the
// room from `pose`, adds axial Gaussian noise sigma(z) = 1.2 mm + 1.9 mm * (z - 0.4)^2
// (a Kinect-like model), and back-projects every pixel to the world frame.
Cloud RenderRoomFrame(const CameraPose& pose, uint32_t seed);

// The benchmark's room frame: RenderRoomFrame(RoomCameraPose(3.5, 4.5, 0, 15), 1).
const Cloud& RoomFrame();
// Camera centre of RoomFrame() in the world frame.
PointF RoomOrigin();

// `kRoomSweepFrames` frames from poses spread over the room (varying position, yaw and
// pitch), for the surface map that the active-sphere radius searches run on.
inline constexpr int kRoomSweepFrames = 16;
const std::vector<Cloud>& RoomSweep();

// The 10 real YCB-Video frames of ../shared/data/ycbv-0000 (or $SKIMAP_YCBV_DIR),
// back-projected with cam_K and depth_scale and moved to the world frame with the
// inverse of (cam_R_w2c, cam_t_w2c). Empty if the data cannot be read; see YcbvError().
const std::vector<Cloud>& YcbvFrames();
const std::string& YcbvError();
// Camera centre of each YcbvFrames() frame in the world frame (for ray casting peers).
const std::vector<PointF>& YcbvOrigins();

// 1 M points uniform in [0, 4 m)^3 (seed 42): the SkiMap paper's radius-search test.
inline constexpr double kUniformSide = 4.0;
const Cloud& UniformPoints();

// One point per voxel centre of a 1 cm "warehouse" surface: a 28 x 28 m floor, 3 m walls
// and 36 crates of 1 x 1 x 1 m. About 13 M distinct voxels at 1 cm.
const Cloud& BigMapPoints();

// `n` points drawn (seed `seed`) from `cloud`: query centres that lie on the data.
Cloud QueryCenters(const Cloud& cloud, size_t n, uint32_t seed);

// Bytes currently allocated from the heap by malloc (mallinfo2: uordblks + hblkhd).
// Counts the main arena only, so measure single-threaded builds.
size_t HeapBytesInUse();

}  // namespace skimap::bench

#endif  // SKIMAP_BENCH_BENCH_DATA_H_
