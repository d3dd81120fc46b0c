// What fleet_bench and pg_failover_bench share: their checks, the 640x480 depth frames
// they stream (the synthetic box scene from the crash test's orbit), the map they stream
// into (5 cm voxels, every 2nd pixel), percentiles, and the report's preamble.
//
//   FILE* out = skimap::bench::ReportToStdout();   // children's output goes to stderr
//   Check(nodes.back()->Start().ok(), "skimapd starts");
//
// Thread safety: free functions; Check and Frame may run on any thread.
#ifndef BENCH_FLEET_COMMON_H_
#define BENCH_FLEET_COMMON_H_

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "skimap/v1/maps.pb.h"
#include "tests/common/synthetic_scene.h"

namespace skimap::bench {

// Prints CHECK FAILED: `what` and exits 1 unless `ok`.
inline void Check(bool ok, const std::string& what) {
  if (ok) return;
  std::fprintf(stderr, "CHECK FAILED: %s\n", what.c_str());
  std::exit(1);
}

// Frame `i` of map `map`: 640x480 depth (RAW_U16, 600 KiB), no colour.
inline v1::Frame Frame(const std::string& map, uint64_t i) {
  testing::SyntheticCamera camera{640, 480, 525, 525, 319.5, 239.5};
  return testing::MakeFrame(map, i, testing::OrbitView(i), camera);
}

inline double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * v.size()))];
}

inline v1::CreateMapRequest CreateRequest(const std::string& id) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(0.05);
  request.mutable_options()->set_pixel_stride(2);
  return request;
}

// Moves this process's stdout to a new stream for the tables (returned) and sends fd 1
// (what forked children inherit) to stderr; prints the run's date, cores and load there.
inline std::FILE* ReportToStdout() {
  std::FILE* out = fdopen(dup(STDOUT_FILENO), "w");
  dup2(STDERR_FILENO, STDOUT_FILENO);
  char date[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  double load = -1;
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &load) != 1) load = -1;
    std::fclose(f);
  }
  std::fprintf(out, "Run of %s, %ld cores, load average %.1f at start.\n\n", date,
               sysconf(_SC_NPROCESSORS_ONLN), load);
  return out;
}

}  // namespace skimap::bench

#endif  // BENCH_FLEET_COMMON_H_
