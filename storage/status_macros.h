// Early-return helpers for absl::Status in the storage layer's SQL sequences.
//
//   SK_RETURN_IF_ERROR(statement.BindInt(1, id));
//   SK_ASSIGN_OR_RETURN(row, statement.Step());   // declares `row` (a reference)
//
// Thread safety: macros.
#ifndef SKIMAP_STORAGE_STATUS_MACROS_H_
#define SKIMAP_STORAGE_STATUS_MACROS_H_

#include "absl/status/status.h"

#define SK_RETURN_IF_ERROR(expr) \
  do {                           \
    absl::Status _s = (expr);    \
    if (!_s.ok()) return _s;     \
  } while (0)

#define SK_ASSIGN_OR_RETURN(lhs, expr)          \
  auto lhs##_or = (expr);                       \
  if (!lhs##_or.ok()) return lhs##_or.status(); \
  auto& lhs = *lhs##_or

#endif  // SKIMAP_STORAGE_STATUS_MACROS_H_
