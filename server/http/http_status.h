// The one place where absl::Status becomes an HTTP status code (the REST counterpart of
// grpc_status.h), and the RestError body every REST error carries.
//
//   INVALID_ARGUMENT, OUT_OF_RANGE                      400
//   UNAUTHENTICATED                                     401
//   PERMISSION_DENIED                                   403
//   NOT_FOUND                                           404
//   ALREADY_EXISTS, ABORTED, FAILED_PRECONDITION        409
//   RESOURCE_EXHAUSTED marked by BodyTooLargeError      413
//   RESOURCE_EXHAUSTED (queues, limits, rates)          429
//   UNIMPLEMENTED                                       501
//   UNAVAILABLE                                         503 (fleet redirects: the message names the
//   owner) DEADLINE_EXCEEDED                                   504 anything else 500
//
// Thread safety: pure functions.
#ifndef SERVER_HTTP_HTTP_STATUS_H_
#define SERVER_HTTP_HTTP_STATUS_H_

#include <string>

#include "absl/status/status.h"
#include "skimap/v1/rest.pb.h"

namespace skimap::server {

// The HTTP status code of `status` (200 for OK), per the table above.
int ToHttpStatus(const absl::Status& status);

// RESOURCE_EXHAUSTED for a request body above the server's limit: the one
// RESOURCE_EXHAUSTED that answers 413 (Payload Too Large) instead of 429.
absl::Status BodyTooLargeError(const std::string& message);

// The error body of `status` (REQUIRES: !status.ok()): code ToHttpStatus(status) unless
// `http_code` overrides it (405, which no status code maps to), the status code's name
// and its message (cut to 1 KiB, like gRPC's).
v1::RestError ToRestError(const absl::Status& status, int http_code = 0);

}  // namespace skimap::server

#endif  // SERVER_HTTP_HTTP_STATUS_H_
