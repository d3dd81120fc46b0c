// cpp-httplib's client for the REST tests. <httplib.h> includes <resolv.h>, whose `_res`
// macro (`#define _res (*__res_state())`) breaks Eigen's headers when they come after it
// in a translation unit (server/app/server.h includes them); the tests use neither resolver
// state nor that name, so it is undefined here. Include this instead of <httplib.h>.
#ifndef TESTS_SERVER_HTTP_HTTP_CLIENT_H_
#define TESTS_SERVER_HTTP_HTTP_CLIENT_H_

#include <httplib.h>

#undef _res

namespace skimap::testing {

// The JSON media type of the REST API's requests and answers.
inline constexpr char kJson[] = "application/json";

}  // namespace skimap::testing

#endif  // TESTS_SERVER_HTTP_HTTP_CLIENT_H_
