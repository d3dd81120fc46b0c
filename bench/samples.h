// Timing samples of a benchmark program: milliseconds, their median and quantiles.
//
//   Samples s; s.Add(Ms(t1 - t0)); ... s.Median(); s.Quantile(0.9);
#ifndef BENCH_SAMPLES_H_
#define BENCH_SAMPLES_H_

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

namespace skimap::bench {

using Clock = std::chrono::steady_clock;
inline double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

struct Samples {
  std::vector<double> ms;
  void Add(double v) { ms.push_back(v); }
  // The q-quantile (0 when empty); sorts the samples.
  double Quantile(double q) {
    if (ms.empty()) return 0;
    std::sort(ms.begin(), ms.end());
    return ms[std::min(ms.size() - 1, size_t(q * double(ms.size())))];
  }
  double Median() { return Quantile(0.5); }
};

}  // namespace skimap::bench

#endif  // BENCH_SAMPLES_H_
