#include "server/core/recognition/instance_proto.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/core/recognition/instance_checks.h"
#include "server/core/recognition/recognition_config.h"

namespace skimap::server {
namespace {

void SetTime(int64_t us, google::protobuf::Timestamp* t) {
  t->set_seconds(us / 1000000);
  t->set_nanos(static_cast<int32_t>(us % 1000000) * 1000);
}

}  // namespace

v1::Instance ToProto(const Instance& i, const recognition::RecognitionModel* model,
                     const std::string& map_id) {
  v1::Instance out;
  out.set_name(absl::StrCat("maps/", map_id, "/instances/", i.id));
  out.set_id(i.id);
  out.set_obj_id(static_cast<int32_t>(i.object_id));
  out.set_object(absl::StrCat("objects/", i.object_id));
  out.set_score_scale(1);
  if (model != nullptr) {
    const int index = model->FindObject(static_cast<int>(i.object_id));
    if (index >= 0) {
      out.set_object_name(model->object(index).name);
      out.set_score_scale(
          InstanceVisibility{.min_score = 1}.MinScore(model->object(index).surface_area));
    }
  }
  v1::Pose* pose = out.mutable_pose();
  pose->mutable_rotation()->set_w(i.q[0]);
  pose->mutable_rotation()->set_x(i.q[1]);
  pose->mutable_rotation()->set_y(i.q[2]);
  pose->mutable_rotation()->set_z(i.q[3]);
  pose->mutable_translation()->set_x(i.t[0]);
  pose->mutable_translation()->set_y(i.t[1]);
  pose->mutable_translation()->set_z(i.t[2]);
  out.set_score(i.score);
  out.set_hypotheses(i.support);
  out.set_frames(i.frames);
  out.mutable_first_seen()->set_frame_sequence(i.first_frame);
  if (i.first_time_us != 0)
    SetTime(i.first_time_us, out.mutable_first_seen()->mutable_frame_time());
  out.mutable_last_seen()->set_frame_sequence(i.last_frame);
  if (i.last_time_us != 0) SetTime(i.last_time_us, out.mutable_last_seen()->mutable_frame_time());
  out.mutable_spread()->set_translation_m(i.spread_t);
  out.mutable_spread()->set_rotation_deg(i.spread_r * 180 / M_PI);
  out.set_fit(i.fit);
  out.set_view_conflict(ViewConflict(i));
  return out;
}

}  // namespace skimap::server
