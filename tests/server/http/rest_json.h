// Reading REST replies in tests: the JSON body as the API's message, the RestError of an
// error reply, each with the test's expectations on status and content type.
//
// Thread safety: pure functions.
#ifndef TESTS_SERVER_HTTP_REST_JSON_H_
#define TESTS_SERVER_HTTP_REST_JSON_H_

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <string>

#include "skimap/v1/rest.pb.h"
#include "tests/server/http/http_client.h"

namespace skimap::testing {

// The JSON of a message (protobuf JSON mapping), as a REST client would send it.
inline std::string ToJsonBody(const google::protobuf::Message& m) {
  std::string json;
  EXPECT_TRUE(google::protobuf::util::MessageToJsonString(m, &json).ok());
  return json;
}

// The body of a 200 reply as message T; fails the test for another status or bad JSON.
template <class T>
T ParseJson(const httplib::Result& r) {
  T message;
  EXPECT_TRUE(r) << "no response: " << httplib::to_string(r.error());
  if (!r) return message;
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(r->body, &message, options).ok())
      << r->body;
  return message;
}

// The RestError body of an error reply whose HTTP status must be `status`.
inline v1::RestError ParseError(const httplib::Result& r, int status) {
  v1::RestError error;
  EXPECT_TRUE(r) << "no response: " << httplib::to_string(r.error());
  if (!r) return error;
  EXPECT_EQ(r->status, status) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/json");
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(r->body, &error).ok()) << r->body;
  EXPECT_EQ(error.code(), status);
  return error;
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_HTTP_REST_JSON_H_
