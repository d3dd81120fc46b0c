// glibc malloc settings for skimapd: a long-running server that allocates and frees
// megabyte buffers on every frame and query (decoded images, voxel batches, 1 MB grid
// replies, gRPC messages).
//
//   int main() { skimap::server::TuneMallocForServer(); ... }   // before any thread starts
//
// By default glibc serves blocks above 128 KiB with mmap and gives freed heap tops back to
// the kernel, so every such buffer costs fresh pages: on this project's VM the page faults
// of one 1 MB occupancy grid reply took 10 ms of a 12 ms query (docs/benchmarks.md,
// "Ingestion over gRPC"). Here blocks up to 32 MiB come from the heap and up to 256 MiB of
// freed memory is kept for reuse: the resident size plateaus that much higher instead of
// rising and falling with every request. Benchmarks that embed the server call it too.
//
// Thread safety: call once, before other threads allocate.
#ifndef SERVER_APP_MALLOC_TUNING_H_
#define SERVER_APP_MALLOC_TUNING_H_

namespace skimap::server {

void TuneMallocForServer();

}  // namespace skimap::server

#endif  // SERVER_APP_MALLOC_TUNING_H_
