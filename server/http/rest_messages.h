// How REST requests and replies become the API's proto messages: JSON bodies in the
// protobuf JSON mapping (protobuf's own JSON utilities, no hand-written JSON), URL query
// parameters and path parameters mapped onto request fields, google.api.http style.
//
//   v1::GetVoxelsRequest r;
//   absl::Status s = FromQueryParameters(call.http.params, {"map"}, {}, &r);
//   // ?box=0,0,0,1,1,1&pageSize=500 -> r.box = {min {0,0,0} max {1,1,1}}, r.page_size 500
//
// Every error is InvalidArgument and starts with what is at fault: `body: ...` or
// `query parameter pageSize: ...`, so a REST client learns which input to fix.
//
// Thread safety: pure functions of their arguments.
#ifndef SERVER_HTTP_REST_MESSAGES_H_
#define SERVER_HTTP_REST_MESSAGES_H_

#include <google/protobuf/message.h>

#include <map>
#include <set>
#include <string>

#include "absl/status/status.h"

namespace skimap::server {

// The message as JSON: lowerCamelCase field names, every field printed (zeros too),
// 64-bit integers as strings, bytes as base64, enums by name, NaN as "NaN".
std::string ToJson(const google::protobuf::Message& message);

// Parses a JSON object into `message` (REQUIRES: `message` is clear). Unknown fields are
// refused. InvalidArgument "body: <protobuf's message, naming the field>" for malformed
// JSON or a value of the wrong type; "body: empty" for an empty body.
absl::Status FromJsonBody(const std::string& body, google::protobuf::Message* message);

// Sets fields of `message` from query parameters:
// - a parameter names a field by its JSON or proto name (pageSize or page_size), with dots
//   for nested fields (region.minX, box.min.x);
// - a repeated scalar field takes repeated parameters and/or comma lists (objIds=1,2);
// - a message field given as one comma list sets its numeric fields depth first, in
//   declaration order: box=minX,minY,minZ,maxX,maxY,maxZ, region=minX,minY,maxX,maxY,
//   sphere=x,y,z,radius, center=x,y,z;
// - enums by name or number, bools as true/false/1/0, bytes as base64.
// Parameters named in `route_parameters` are the route's own (format) and skipped; the
// fields in `path_fields` are set from the path and cannot be given. InvalidArgument
// "query parameter <name>: ..." for an unknown parameter (listing those the route takes),
// a malformed value or a scalar given twice.
absl::Status FromQueryParameters(const std::multimap<std::string, std::string>& parameters,
                                 const std::set<std::string>& path_fields,
                                 const std::set<std::string>& route_parameters,
                                 google::protobuf::Message* message);

// Sets the top-level string field `field` (REQUIRES: it exists) to `value`, taken from the
// request's path. InvalidArgument "<field>: ..." if the body already set it to another
// value (the path and the body must agree).
absl::Status BindPathField(const std::string& field, const std::string& value,
                           google::protobuf::Message* message);

}  // namespace skimap::server

#endif  // SERVER_HTTP_REST_MESSAGES_H_
