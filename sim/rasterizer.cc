// Scanline-free edge-function rasterizer. See rasterizer.h for the contract.
#include "sim/rasterizer.h"

#include <algorithm>
#include <cmath>

namespace skimap::sim {
namespace {

struct ClipVertex {
  Eigen::Vector3f p;  // camera frame
  Eigen::Vector2f uv;
};

// Clips a triangle against z >= near; returns 0, 3 or 4 vertices (a convex polygon).
int ClipNear(const ClipVertex in[3], float near, ClipVertex out[4]) {
  int n = 0;
  for (int i = 0; i < 3; ++i) {
    const ClipVertex& a = in[i];
    const ClipVertex& b = in[(i + 1) % 3];
    const bool ia = a.p.z() >= near, ib = b.p.z() >= near;
    if (ia) out[n++] = a;
    if (ia != ib) {
      const float t = (near - a.p.z()) / (b.p.z() - a.p.z());
      out[n++] = {a.p + t * (b.p - a.p), a.uv + t * (b.uv - a.uv)};
    }
  }
  return n;
}

// What a rasterized pixel does: shade (full render) or mark coverage.
struct Target {
  const dataset::Intrinsics* K;
  RenderOutput* out = nullptr;  // full render
  cv::Mat* coverage = nullptr;  // coverage only
};

// Rasterizes one clipped triangle (camera frame) with precomputed shade and normal.
void RasterTriangle(const ClipVertex& v0, const ClipVertex& v1, const ClipVertex& v2,
                    const cv::Mat* tex, const Eigen::Vector3f& shade, const Eigen::Vector3f& n,
                    uint16_t id, const Target& tg) {
  const dataset::Intrinsics& K = *tg.K;
  const ClipVertex* v[3] = {&v0, &v1, &v2};
  float sx[3], sy[3], iz[3];
  for (int i = 0; i < 3; ++i) {
    iz[i] = 1.f / v[i]->p.z();
    sx[i] = static_cast<float>(K.fx) * v[i]->p.x() * iz[i] + static_cast<float>(K.cx);
    sy[i] = static_cast<float>(K.fy) * v[i]->p.y() * iz[i] + static_cast<float>(K.cy);
  }
  const float area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sx[2] - sx[0]) * (sy[1] - sy[0]);
  if (std::abs(area) < 1e-12f) return;
  const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({sx[0], sx[1], sx[2]}))));
  const int x1 =
      std::min(K.width - 1, static_cast<int>(std::floor(std::max({sx[0], sx[1], sx[2]}))));
  const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({sy[0], sy[1], sy[2]}))));
  const int y1 =
      std::min(K.height - 1, static_cast<int>(std::floor(std::max({sy[0], sy[1], sy[2]}))));
  if (x0 > x1 || y0 > y1) return;
  const float inv_area = 1.f / area;
  // Attributes divided by z, interpolated linearly in screen space.
  float uz[3], vz[3];
  for (int i = 0; i < 3; ++i) {
    uz[i] = v[i]->uv.x() * iz[i];
    vz[i] = v[i]->uv.y() * iz[i];
  }
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy);
  const float cx = static_cast<float>(K.cx), cy = static_cast<float>(K.cy);
  for (int y = y0; y <= y1; ++y) {
    const float py = static_cast<float>(y);
    // Barycentric weights are affine in x: w_i(x) = a_i * x + b_i.
    float a[3], b[3];
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3, k = (i + 2) % 3;
      a[i] = -(sy[k] - sy[j]) * inv_area;
      b[i] = ((sx[k] - sx[j]) * (py - sy[j]) + (sy[k] - sy[j]) * sx[j]) * inv_area;
    }
    float* zrow = tg.out ? tg.out->depth.ptr<float>(y) : nullptr;
    for (int x = x0; x <= x1; ++x) {
      const float px = static_cast<float>(x);
      const float w0 = a[0] * px + b[0], w1 = a[1] * px + b[1], w2 = a[2] * px + b[2];
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      if (tg.coverage) {
        tg.coverage->at<uint8_t>(y, x) = 255;
        continue;
      }
      const float inv_z = w0 * iz[0] + w1 * iz[1] + w2 * iz[2];
      const float z = 1.f / inv_z;
      if (zrow[x] != 0 && zrow[x] <= z) continue;
      zrow[x] = z;
      tg.out->ids.at<uint16_t>(y, x) = id;
      const float u = (w0 * uz[0] + w1 * uz[1] + w2 * uz[2]) * z;
      const float vv = (w0 * vz[0] + w1 * vz[1] + w2 * vz[2]) * z;
      const cv::Vec3b& c = SampleTexture(*tex, u, vv);
      cv::Vec3b& dst = tg.out->bgr.at<cv::Vec3b>(y, x);
      for (int ch = 0; ch < 3; ++ch) {
        dst[ch] = static_cast<uint8_t>(std::min(255.f, c[ch] * shade[ch]));
      }
      const Eigen::Vector3f ray((px - cx) / fx, (py - cy) / fy, 1.f);
      tg.out->incidence.at<float>(y, x) = std::abs(n.dot(ray)) / ray.norm();
    }
  }
}

void RasterInstance(const Instance& inst, const Eigen::Isometry3f& T_cw, const Lighting* light,
                    float near, const Target& tg) {
  const Mesh& m = *inst.mesh;
  const Eigen::Isometry3f T_cm = T_cw * inst.T_wm;
  std::vector<Eigen::Vector3f> pc(m.positions.size());
  for (size_t i = 0; i < pc.size(); ++i) pc[i] = T_cm * m.positions[i];
  Eigen::Vector3f light_c = Eigen::Vector3f::Zero();
  if (light) light_c = (T_cw.linear() * light->dir_world).normalized();
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    const Eigen::Vector3f& p0 = pc[tri[0]];
    Eigen::Vector3f n = (pc[tri[1]] - p0).cross(pc[tri[2]] - p0);
    if (n.dot(p0) >= 0) {  // back face (camera at the origin)
      if (!inst.two_sided) continue;
      n = -n;
    }
    if (pc[tri[0]].z() < near && pc[tri[1]].z() < near && pc[tri[2]].z() < near) continue;
    const Eigen::Vector3f nn = n.normalized();
    Eigen::Vector3f shade(1, 1, 1);
    if (light) {
      const float lambert = std::max(0.f, -nn.dot(light_c));
      shade = light->tint * (light->exposure * (light->ambient + light->diffuse * lambert));
    }
    ClipVertex in[3], poly[4];
    for (int k = 0; k < 3; ++k) in[k] = {pc[tri[k]], m.uvs[tri[k]]};
    const int np = ClipNear(in, near, poly);
    const cv::Mat* tex = m.textures[m.tri_texture[t]].get();
    for (int k = 1; k + 1 < np; ++k) {
      RasterTriangle(poly[0], poly[k], poly[k + 1], tex, shade, nn, inst.id, tg);
    }
  }
}

}  // namespace

void Render(const std::vector<Instance>& instances, const dataset::Intrinsics& K,
            const Eigen::Isometry3f& T_wc, const Lighting& light, RenderOutput* out, float near) {
  out->bgr.create(K.height, K.width, CV_8UC3);
  out->depth.create(K.height, K.width, CV_32FC1);
  out->ids.create(K.height, K.width, CV_16UC1);
  out->incidence.create(K.height, K.width, CV_32FC1);
  out->bgr.setTo(cv::Scalar::all(0));
  out->depth.setTo(0);
  out->ids.setTo(0);
  out->incidence.setTo(0);
  const Eigen::Isometry3f T_cw = T_wc.inverse();
  Target tg{&K, out, nullptr};
  for (const Instance& inst : instances) RasterInstance(inst, T_cw, &light, near, tg);
}

cv::Mat RenderCoverage(const Instance& instance, const dataset::Intrinsics& K,
                       const Eigen::Isometry3f& T_wc, float near) {
  cv::Mat cov(K.height, K.width, CV_8UC1, cv::Scalar(0));
  Target tg{&K, nullptr, &cov};
  RasterInstance(instance, T_wc.inverse(), nullptr, near, tg);
  return cov;
}

}  // namespace skimap::sim
