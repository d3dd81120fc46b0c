#include "client/cli/single_view.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "client/cli/dataset_frames.h"

namespace skimap::client {

std::vector<SingleViewPose> EstimateSingleViewPoses(
    const google::protobuf::RepeatedPtrField<v1::FeatureMatch>& matches,
    const dataset::Intrinsics& K, const SingleViewOptions& options) {
  std::map<int, std::pair<std::vector<cv::Point3f>, std::vector<cv::Point2f>>> by_object;
  for (const v1::FeatureMatch& m : matches) {
    auto& [model, image] = by_object[m.obj_id()];
    model.emplace_back(m.model_point().x(), m.model_point().y(), m.model_point().z());
    image.emplace_back(m.x(), m.y());
  }
  const cv::Matx33d camera(K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
  std::vector<SingleViewPose> poses;
  for (const auto& [obj_id, correspondences] : by_object) {
    const auto& [model, image] = correspondences;
    if (static_cast<int>(model.size()) < std::max(options.min_inliers, 5)) continue;
    cv::Mat rvec, tvec;
    std::vector<int> inliers;
    cv::UsacParams usac;
    usac.confidence = 0.999;
    usac.maxIterations = options.iterations;
    usac.threshold = options.reprojection_px;
    usac.score = cv::SCORE_METHOD_MSAC;
    usac.loMethod = cv::LOCAL_OPTIM_INNER_LO;
    usac.sampler = cv::SAMPLING_UNIFORM;
    usac.randomGeneratorState = 0x5eed;  // the baseline's answer is a function of its input
    usac.isParallel = false;
    const bool found =
        cv::solvePnPRansac(model, image, camera, cv::noArray(), rvec, tvec, inliers, usac);
    if (!found || static_cast<int>(inliers.size()) < options.min_inliers) continue;
    std::vector<cv::Point3f> model_in;
    std::vector<cv::Point2f> image_in;
    for (int i : inliers) {
      model_in.push_back(model[i]);
      image_in.push_back(image[i]);
    }
    cv::solvePnPRefineLM(model_in, image_in, camera, cv::noArray(), rvec, tvec);
    cv::Matx33d R;
    cv::Rodrigues(rvec, R);
    SingleViewPose pose;
    pose.obj_id = obj_id;
    Eigen::Matrix3d rotation;
    cv::cv2eigen(cv::Mat(R), rotation);
    pose.T_cm.linear() = rotation;
    pose.T_cm.translation() =
        Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
    const double z = pose.T_cm.translation().z();
    if (!(z > 0.05 && z < 10)) continue;
    pose.inliers = static_cast<int>(inliers.size());
    pose.matches = static_cast<int>(model.size());
    poses.push_back(pose);
  }
  std::sort(poses.begin(), poses.end(), [](const SingleViewPose& a, const SingleViewPose& b) {
    return a.inliers != b.inliers ? a.inliers > b.inliers : a.obj_id < b.obj_id;
  });
  return poses;
}

void SingleViewScene::Add(const std::vector<SingleViewPose>& poses, const Eigen::Isometry3d& T_wc) {
  for (const SingleViewPose& p : poses) {
    auto [it, inserted] = best_.try_emplace(p.obj_id, Best{T_wc * p.T_cm, p.inliers});
    if (!inserted && p.inliers > it->second.inliers) it->second = {T_wc * p.T_cm, p.inliers};
  }
}

std::vector<v1::Instance> SingleViewScene::Instances() const {
  std::vector<v1::Instance> out;
  for (const auto& [obj_id, best] : best_) {
    v1::Instance& i = out.emplace_back();
    i.set_id(obj_id);
    i.set_obj_id(obj_id);
    i.set_score(best.inliers);
    ToApiPose(best.T_wm, i.mutable_pose());
  }
  return out;
}

}  // namespace skimap::client
