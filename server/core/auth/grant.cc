#include "server/core/auth/grant.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "base/echo.h"

namespace skimap::server::auth {

const char* RoleName(Role role) {
  switch (role) {
    case Role::kRead:
      return "read";
    case Role::kWrite:
      return "write";
    case Role::kAdmin:
      return "admin";
  }
  return "?";
}

bool ParseRole(absl::string_view name, Role* role) {
  for (Role r : {Role::kRead, Role::kWrite, Role::kAdmin}) {
    if (name == RoleName(r)) {
      *role = r;
      return true;
    }
  }
  return false;
}

absl::string_view MapIdOf(absl::string_view resource) {
  constexpr absl::string_view kPrefix = "maps/";
  if (resource.substr(0, kPrefix.size()) != kPrefix) return {};
  resource.remove_prefix(kPrefix.size());
  return resource.substr(0, resource.find('/'));
}

bool Grant::AllowsMap(absl::string_view resource) const {
  if (maps.empty()) return true;
  const absl::string_view id = MapIdOf(resource);
  return !id.empty() && std::find(maps.begin(), maps.end(), id) != maps.end();
}

absl::Status Grant::Check(Role needed) const {
  if (role < needed) {
    return absl::PermissionDeniedError(absl::StrCat("this call needs the ", RoleName(needed),
                                                    " role; token ", Echo(label), " has ",
                                                    RoleName(role)));
  }
  return absl::OkStatus();
}

absl::Status Grant::CheckMap(Role needed, absl::string_view resource) const {
  if (absl::Status s = Check(needed); !s.ok()) return s;
  if (!AllowsMap(resource)) {
    return absl::PermissionDeniedError(absl::StrCat("token ", Echo(label), " may not access ",
                                                    Echo(resource), " (outside its map scope)"));
  }
  return absl::OkStatus();
}

}  // namespace skimap::server::auth
