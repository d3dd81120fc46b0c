#include "server/http/http_status.h"

#include "absl/strings/cord.h"

namespace skimap::server {
namespace {

// Marks a RESOURCE_EXHAUSTED that is about the request's size (BodyTooLargeError).
constexpr char kBodyTooLargeUrl[] = "type.skimap.dev/http.BodyTooLarge";
constexpr size_t kMaxMessageBytes = 1024;

}  // namespace

int ToHttpStatus(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kOk:
      return 200;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kOutOfRange:
      return 400;
    case absl::StatusCode::kUnauthenticated:
      return 401;
    case absl::StatusCode::kPermissionDenied:
      return 403;
    case absl::StatusCode::kNotFound:
      return 404;
    case absl::StatusCode::kAlreadyExists:
    case absl::StatusCode::kAborted:
    case absl::StatusCode::kFailedPrecondition:
      return 409;
    case absl::StatusCode::kResourceExhausted:
      return status.GetPayload(kBodyTooLargeUrl).has_value() ? 413 : 429;
    case absl::StatusCode::kUnimplemented:
      return 501;
    case absl::StatusCode::kUnavailable:
      return 503;
    case absl::StatusCode::kDeadlineExceeded:
      return 504;
    default:
      return 500;
  }
}

absl::Status BodyTooLargeError(const std::string& message) {
  absl::Status status = absl::ResourceExhaustedError(message);
  status.SetPayload(kBodyTooLargeUrl, absl::Cord("1"));
  return status;
}

v1::RestError ToRestError(const absl::Status& status, int http_code) {
  v1::RestError error;
  error.set_code(http_code != 0 ? http_code : ToHttpStatus(status));
  error.set_status(absl::StatusCodeToString(status.code()));
  std::string message(status.message().substr(0, kMaxMessageBytes));
  if (status.message().size() > kMaxMessageBytes) message += "...";
  error.set_message(std::move(message));
  return error;
}

}  // namespace skimap::server
