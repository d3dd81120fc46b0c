// The peer of ingest_bench: Open3D 0.16's ScalableTSDFVolume (libopen3d-dev), given the
// same real frames as the server, already decoded and converted before any clock starts.
#ifndef BENCH_OPEN3D_PEER_H_
#define BENCH_OPEN3D_PEER_H_

#include <Eigen/Geometry>
#include <memory>

#include "bench/ycbv_frames.h"
#include "open3d/camera/PinholeCameraIntrinsic.h"
#include "open3d/geometry/RGBDImage.h"
#include "open3d/pipelines/integration/ScalableTSDFVolume.h"

namespace skimap::bench {

struct Open3dFrame {
  std::shared_ptr<open3d::geometry::RGBDImage> rgbd;
  open3d::camera::PinholeCameraIntrinsic intrinsic;
  Eigen::Matrix4d extrinsic;  // world -> camera
};

// The frame's decoded depth and colour as an RGBDImage (depth truncated at max_depth), its
// camera, and its pose moved shift_x metres along world x.
Open3dFrame ToOpen3d(const RealFrame& f, double shift_x, double max_depth);

// A volume of `voxel` edge, truncation 4 voxels, RGB colour.
std::unique_ptr<open3d::pipelines::integration::ScalableTSDFVolume> NewVolume(double voxel);

}  // namespace skimap::bench

#endif  // BENCH_OPEN3D_PEER_H_
