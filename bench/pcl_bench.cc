// PCL (libpcl-dev 1.13) side of the benchmarks: pcl::octree::OctreePointCloudSearch over
// the distinct voxel centres of each workload (so that it answers exactly what the voxel
// maps answer), queried with radiusSearch (indices and squared distances into reused
// vectors). Its leaf size is kPclLeafM (see docs/benchmarks.md for why).
#include <pcl/octree/octree_search.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <vector>

#include "bench/bench_harness.h"
#include "bench/bench_register.h"

namespace skimap::bench {
namespace {

// Octree leaf edge in metres, independent of the map resolution.
constexpr double kPclLeafM = SKIMAP_BENCH_PCL_LEAF_M;

class PclOctreeAdapter {
 public:
  static constexpr bool kStoresPoints = true;
  explicit PclOctreeAdapter(double /*res*/)
      : cloud_(new pcl::PointCloud<pcl::PointXYZ>), octree_(kPclLeafM) {}

  // Appends the points and rebuilds the octree over all of them.
  void Insert(const Cloud& cloud) {
    for (const PointF& p : cloud) cloud_->push_back(pcl::PointXYZ(p.x, p.y, p.z));
    octree_.deleteTree();
    octree_.setInputCloud(cloud_);
    octree_.addPointsFromInputCloud();
  }
  size_t RadiusSearch(const PointF& c, double r) const {
    return octree_.radiusSearch(pcl::PointXYZ(c.x, c.y, c.z), r, indices_, sqr_dists_);
  }
  size_t Voxels() const { return cloud_->size(); }
  size_t LibBytes() const { return 0; }
  void ReleaseScratch() {
    indices_ = {};
    sqr_dists_ = {};
  }

 private:
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::octree::OctreePointCloudSearch<pcl::PointXYZ> octree_;
  mutable pcl::Indices indices_;  // reused result buffers
  mutable std::vector<float> sqr_dists_;
};

const bool pcl_registered = [] {
  RegisterRadius<PclOctreeAdapter>("PclOctree");
  RegisterMemory<PclOctreeAdapter>("PclOctree", /*big=*/false);
  return true;
}();

}  // namespace
}  // namespace skimap::bench
