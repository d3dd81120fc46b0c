// Roles and grants: what a bearer token may do (auth/authorizer.h hands them out).
//
//   Roles are ordered: kRead < kWrite < kAdmin; a token of a role may do everything the
//   roles below it may. A grant may be limited to some maps (its scope):
//
//   Grant grant{.role = Role::kWrite, .maps = {"kitchen"}};
//   grant.CheckMap(Role::kRead, "maps/kitchen");          // OK
//   grant.CheckMap(Role::kAdmin, "maps/kitchen");         // PermissionDenied (role)
//   grant.CheckMap(Role::kRead, "maps/hall/instances/3"); // PermissionDenied (scope)
//   grant.Check(Role::kRead);                             // OK: a call about no one map
//
// Messages name the role needed and the map, never the token.
//
// Thread safety: a value; const methods are safe from any thread.
#ifndef SERVER_CORE_AUTH_GRANT_H_
#define SERVER_CORE_AUTH_GRANT_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace skimap::server::auth {

enum class Role { kRead = 1, kWrite = 2, kAdmin = 3 };

// "read", "write", "admin".
const char* RoleName(Role role);
// The role spelled `name` ("read", "write", "admin"); false for anything else.
bool ParseRole(absl::string_view name, Role* role);

// The map id a resource name is about: "maps/kitchen" and "maps/kitchen/instances/3" ->
// "kitchen"; "" for a name that is not under maps/.
absl::string_view MapIdOf(absl::string_view resource);

struct Grant {
  Role role = Role::kRead;
  // Map ids this grant is limited to; empty = every map.
  std::vector<std::string> maps;
  // The token's label in the token file (for messages and logs; never the token itself).
  std::string label;

  // Every role on every map: what a caller gets when auth is off.
  static Grant Everything() { return Grant{.role = Role::kAdmin, .label = "auth off"}; }

  bool Scoped() const { return !maps.empty(); }
  // True when `resource` ("maps/ID[/...]") is a map within the scope (always when unscoped).
  bool AllowsMap(absl::string_view resource) const;
  // OK when the role is at least `needed`; PermissionDenied naming the role otherwise.
  absl::Status Check(Role needed) const;
  // For a call about one map: Check(needed), then the map `resource` names must be within
  // the scope (a scoped grant refuses a resource that names no map). PermissionDenied
  // naming the map otherwise.
  absl::Status CheckMap(Role needed, absl::string_view resource) const;
};

// Removes the maps outside the grant's scope from a ListMaps reply.
template <class ListMapsResponse>
void KeepMapsInScope(const Grant& grant, ListMapsResponse* reply) {
  if (!grant.Scoped()) return;
  auto* maps = reply->mutable_maps();
  for (int i = maps->size() - 1; i >= 0; --i) {
    if (!grant.AllowsMap(maps->Get(i).name())) maps->DeleteSubrange(i, 1);
  }
}

}  // namespace skimap::server::auth

#endif  // SERVER_CORE_AUTH_GRANT_H_
