// The active sphere (paper §4.2, Eq. 6): the part of the map where a frame's hypotheses
// are estimated, M_T_S = M_T_C · T_z(d): centred `distance` metres along the camera's
// optical axis, with radius `radius` — the paper's fixed rule (d = 1 m there).
// With distance 0, the scene rule: d is the median depth of the frame's labelled features,
// and the radius grows to take in 90 % of them (but at most kMaxSceneRadius): the sphere
// follows what the camera sees, near or far.
//
// Thread safety: pure function.
#ifndef PERCEPTION_RECOGNITION_ACTIVE_SPHERE_H_
#define PERCEPTION_RECOGNITION_ACTIVE_SPHERE_H_

#include "perception/recognition/label_observer.h"
#include "perception/recognition/pose_voting.h"
#include "perception/rgbd_frame.h"

namespace skimap::recognition {

inline constexpr double kMaxSceneRadius = 2.5;  // metres

// REQUIRES: distance >= 0, radius > 0. Without labelled features the scene rule uses 1 m.
Sphere ActiveSphere(const perception::CameraPose& pose, const LabelObservations& observations,
                    double distance, double radius);

}  // namespace skimap::recognition

#endif  // PERCEPTION_RECOGNITION_ACTIVE_SPHERE_H_
