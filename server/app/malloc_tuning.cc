#include "server/app/malloc_tuning.h"

#include <malloc.h>

namespace skimap::server {

void TuneMallocForServer() {
  // Best effort: a C library without these knobs keeps its defaults.
  (void)mallopt(M_MMAP_THRESHOLD, 32 << 20);
  (void)mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace skimap::server
