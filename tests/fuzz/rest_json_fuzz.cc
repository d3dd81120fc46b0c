// Fuzz target: REST JSON parsing, as the HTTP adapter does it for every route that takes a
// JSON body (server/http/rest_request.h ParseRequest, the function rest_routes.cc calls):
//
//   POST /v1/maps                     CreateMapRequest
//   POST /v1/maps/{map}:radiusSearch  RadiusSearchRequest  (map bound from the path)
//   POST /v1/maps/{map}/frames        Frame                (map bound from the path)
//   POST /v1/maps/{map}:updatePoses   UpdatePosesRequest   (map bound from the path)
//
// Input: u8 route (taken modulo 4), then the body's bytes. Parsing must answer OK or
// INVALID_ARGUMENT with a message; a request that parsed must print as JSON (ToJson) and
// that JSON must parse back into the same request, as a client echoing it would send it.
#include <google/protobuf/util/message_differencer.h>

#include <cstdint>
#include <map>
#include <string>
#include <type_traits>

#include "server/http/rest_request.h"
#include "skimap/v1/frames.pb.h"
#include "skimap/v1/maps.pb.h"
#include "skimap/v1/queries.pb.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

using server::Binding;
using server::Body;
using server::RestCall;

const std::multimap<std::string, std::string> kNoQuery;

template <class Request>
void Check(const std::string& body, const std::vector<Binding>& bindings) {
  RestCall call{.query = kNoQuery, .body = body};
  if (!bindings.empty()) call.path["map"] = "fuzz";
  absl::StatusOr<Request> request = server::ParseRequest<Request>(call, Body::kJson, bindings);
  if (!request.ok()) {
    if (request.status().code() != absl::StatusCode::kInvalidArgument) {
      Fail("a REST body refused with a code other than INVALID_ARGUMENT");
    }
    if (request.status().message().empty()) Fail("a REST body refused without a message");
    return;
  }
  if constexpr (!std::is_same_v<Request, v1::CreateMapRequest>) {
    if (request->map() != "maps/fuzz") Fail("the path's map was not bound");
  }
  const std::string json = server::ToJson(*request);
  Request again;
  if (!server::FromJsonBody(json, &again).ok()) Fail("a parsed request's JSON does not parse");
  // Bytes first (NaN equals itself there), then values: -0.0 prints as 0 (found by
  // fuzzing: "resolution": -.0), the same number; and a proto3 field without presence
  // holding -0.0 counts as set where its reprint 0 does not ("radius": -.0), so the
  // values are compared with unset fields as their defaults (Equivalent).
  if (again.SerializeAsString() != request->SerializeAsString() &&
      !google::protobuf::util::MessageDifferencer::Equivalent(again, *request)) {
    Fail("a parsed request's JSON parses into another request");
  }
}

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const int route = in.U8() % 4;
  const std::string body(in.Rest());
  const std::vector<server::Binding> map = {{"map", "maps/{map}"}};
  switch (route) {
    case 0:
      Check<v1::CreateMapRequest>(body, {});
      break;
    case 1:
      Check<v1::RadiusSearchRequest>(body, map);
      break;
    case 2:
      Check<v1::Frame>(body, map);
      break;
    default:
      Check<v1::UpdatePosesRequest>(body, map);
  }
  return 0;
}
