#include "bench/open3d_peer.h"

#include <cstring>

#include "open3d/geometry/Image.h"

namespace skimap::bench {

Open3dFrame ToOpen3d(const RealFrame& f, double shift_x, double max_depth) {
  open3d::geometry::Image depth, color;
  depth.Prepare(f.depth.width, f.depth.height, 1, 2);
  std::memcpy(depth.data_.data(), f.depth.pixels.data(), f.depth.pixels.size() * 2);
  color.Prepare(f.color.width, f.color.height, 3, 1);
  std::memcpy(color.data_.data(), f.color.rgb.data(), f.color.rgb.size());
  Open3dFrame out;
  out.rgbd = open3d::geometry::RGBDImage::CreateFromColorAndDepth(
      color, depth, 1.0 / f.api.depth_scale(), max_depth, /*convert_rgb_to_intensity=*/false);
  const v1::CameraIntrinsics& k = f.api.intrinsics();
  out.intrinsic = open3d::camera::PinholeCameraIntrinsic(int(k.width()), int(k.height()), k.fx(),
                                                         k.fy(), k.cx(), k.cy());
  const v1::Pose& p = f.api.pose();
  Eigen::Isometry3d cam_to_world = Eigen::Isometry3d::Identity();
  cam_to_world.linear() =
      Eigen::Quaterniond(p.rotation().w(), p.rotation().x(), p.rotation().y(), p.rotation().z())
          .toRotationMatrix();
  cam_to_world.translation() =
      Eigen::Vector3d(p.translation().x() + shift_x, p.translation().y(), p.translation().z());
  out.extrinsic = cam_to_world.inverse().matrix();
  return out;
}

std::unique_ptr<open3d::pipelines::integration::ScalableTSDFVolume> NewVolume(double voxel) {
  return std::make_unique<open3d::pipelines::integration::ScalableTSDFVolume>(
      voxel, 4 * voxel, open3d::pipelines::integration::TSDFVolumeColorType::RGB8);
}

}  // namespace skimap::bench
