#include "client/cli/instances_command.h"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "Eigen/Geometry"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"

namespace skimap::client {
namespace {

// `count` comma-separated numbers of flag --`flag`.
absl::StatusOr<std::vector<double>> Numbers(const std::string& text, size_t count,
                                            const std::string& flag) {
  std::vector<double> out;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    double v = 0;
    if (!absl::SimpleAtod(part, &v)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", flag, ": \"", part, "\" is not a number"));
    }
    out.push_back(v);
  }
  if (out.size() != count) {
    return absl::InvalidArgumentError(
        absl::StrCat("--", flag, " needs ", count, " comma-separated numbers, got ", out.size()));
  }
  return out;
}

v1::Vec3 Vec(double x, double y, double z) {
  v1::Vec3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

Eigen::Quaterniond Rotation(const v1::Instance& i) {
  const v1::Quaternion& q = i.pose().rotation();
  return Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized();
}

}  // namespace

absl::StatusOr<v1::ListInstancesRequest> InstancesRequest(const InstancesOptions& options) {
  v1::ListInstancesRequest request;
  request.set_map("maps/" + options.map_id);
  request.set_page_size(1000);
  request.set_min_score(options.min_score);
  if (!options.box.empty() && !options.sphere.empty()) {
    return absl::InvalidArgumentError("--box and --sphere: give one region, not both");
  }
  if (!options.box.empty()) {
    absl::StatusOr<std::vector<double>> b = Numbers(options.box, 6, "box");
    if (!b.ok()) return b.status();
    *request.mutable_box()->mutable_min() = Vec((*b)[0], (*b)[1], (*b)[2]);
    *request.mutable_box()->mutable_max() = Vec((*b)[3], (*b)[4], (*b)[5]);
  }
  if (!options.sphere.empty()) {
    absl::StatusOr<std::vector<double>> s = Numbers(options.sphere, 4, "sphere");
    if (!s.ok()) return s.status();
    *request.mutable_sphere()->mutable_center() = Vec((*s)[0], (*s)[1], (*s)[2]);
    request.mutable_sphere()->set_radius((*s)[3]);
  }
  if (!options.objects.empty()) {
    for (absl::string_view part : absl::StrSplit(options.objects, ',')) {
      int id = 0;
      if (!absl::SimpleAtoi(part, &id)) {
        return absl::InvalidArgumentError(
            absl::StrCat("--objects: \"", part, "\" is not an object id"));
      }
      request.add_obj_ids(id);
    }
  }
  return request;
}

std::string FormatInstances(const std::vector<v1::Instance>& instances, bool json) {
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const v1::Instance& i : instances) {
      const Eigen::Matrix3d R = Rotation(i).toRotationMatrix();
      const v1::Vec3& t = i.pose().translation();
      nlohmann::json r = nlohmann::json::array();
      for (int row = 0; row < 3; ++row) {
        for (int col = 0; col < 3; ++col) r.push_back(R(row, col));
      }
      out.push_back({{"id", i.id()},
                     {"obj_id", i.obj_id()},
                     {"object_name", i.object_name()},
                     {"score", i.score()},
                     {"fit", i.fit()},
                     {"frames", i.frames()},
                     {"hypotheses", i.hypotheses()},
                     {"R", r},
                     {"t", {t.x() * 1000, t.y() * 1000, t.z() * 1000}}});
    }
    return out.dump(2) + "\n";
  }
  if (instances.empty()) return "(no instances)\n";
  std::string text;
  for (const v1::Instance& i : instances) {
    const Eigen::AngleAxisd aa(Rotation(i));
    const v1::Vec3& t = i.pose().translation();
    absl::StrAppendFormat(&text,
                          "%s  obj %d %s  at [%.3f %.3f %.3f] m  turned %.1f deg about "
                          "[%.2f %.2f %.2f]  score %.1f  fit %.2f  frames %llu\n",
                          i.name(), i.obj_id(), i.object_name(), t.x(), t.y(), t.z(),
                          aa.angle() * 180 / M_PI, aa.axis().x(), aa.axis().y(), aa.axis().z(),
                          i.score(), i.fit(), static_cast<unsigned long long>(i.frames()));
  }
  return text;
}

absl::Status RunInstancesCommand(MapClient& client, const InstancesOptions& options) {
  absl::StatusOr<v1::ListInstancesRequest> request = InstancesRequest(options);
  if (!request.ok()) return request.status();
  absl::StatusOr<std::vector<v1::Instance>> instances = client.ListAllInstances(*request);
  if (!instances.ok()) return instances.status();
  std::fputs(FormatInstances(*instances, options.json).c_str(), stdout);
  return absl::OkStatus();
}

}  // namespace skimap::client
