// Software rasterizer: z-buffer, perspective-correct texturing, Lambert + ambient shading.
// Produces the ideal (noise-free) colour, depth, instance-id and incidence images of one
// view; sensor effects are added by depth_noise.h.
//
// Camera: pinhole, OpenCV axes (x right, y down, z forward), pixel centres at integers.
// Triangles are clipped against the near plane, back faces are culled.
//
// Thread safety: Render() only reads its inputs; concurrent calls with distinct outputs
// are safe (the generator renders one frame per thread).
#ifndef SKIMAP_SIM_RASTERIZER_H_
#define SKIMAP_SIM_RASTERIZER_H_

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "dataset/types.h"
#include "sim/mesh.h"

namespace skimap::sim {

// A mesh placed in the world. id 0 = unlabelled (walls, furniture); ids > 0 appear in
// the id image so the caller can make per-object masks.
struct Instance {
  const Mesh* mesh = nullptr;  // not owned; must outlive the Render call
  Eigen::Isometry3f T_wm = Eigen::Isometry3f::Identity();  // world <- model
  uint16_t id = 0;
  // Draw back faces too, lit as seen (models from elsewhere may wind their triangles
  // either way).
  bool two_sided = false;
};

// Per-sequence lighting: one directional light plus ambient, then exposure and tint.
struct Lighting {
  Eigen::Vector3f dir_world{0.3f, 0.2f, -1.0f};  // direction the light travels (normalised)
  float ambient = 0.45f;
  float diffuse = 0.65f;
  float exposure = 1.0f;          // multiplies the final colour
  Eigen::Vector3f tint{1, 1, 1};  // B, G, R gains
};

// Ideal images of one view.
struct RenderOutput {
  cv::Mat bgr;        // CV_8UC3; black where nothing was hit
  cv::Mat depth;      // CV_32FC1 metres along the optical axis (z); 0 where nothing was hit
  cv::Mat ids;        // CV_16UC1 Instance::id of the visible surface; 0 = background/unlabelled
  cv::Mat incidence;  // CV_32FC1 |cos| of the angle between view ray and surface normal
};

// Renders `instances` seen from T_wc (world <- camera). near: clip distance (metres).
// Reuses the buffers in `out` when their size matches.
void Render(const std::vector<Instance>& instances, const dataset::Intrinsics& K,
            const Eigen::Isometry3f& T_wc, const Lighting& light, RenderOutput* out,
            float near = 0.05f);

// Pixel coverage of one instance alone (occlusion by others ignored): CV_8UC1 0/255.
// Used for BOP px_count_all / bbox_obj.
cv::Mat RenderCoverage(const Instance& instance, const dataset::Intrinsics& K,
                       const Eigen::Isometry3f& T_wc, float near = 0.05f);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_RASTERIZER_H_
