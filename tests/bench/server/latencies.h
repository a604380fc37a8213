// Call latencies by method, for the service load programs: percentiles,
// rates and error counts.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace oaipp::bench {

// Milliseconds from `start` until now, on the steady clock.
inline double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// The q-quantile (0..1) of `v` (sorted in place); 0 when it is empty.
inline double Quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

class Latencies {
 public:
  // One call: when it started (seconds since the run began; for the
  // timeline), its method, how long it took and whether it succeeded.
  struct Call {
    double start_s = 0.0;
    std::string method;
    double ms = 0.0;
    bool ok = true;
  };

  void Add(const std::string& method, double ms, bool ok, double start_s = 0.0) {
    std::lock_guard<std::mutex> lock(mu_);
    samples_[method].push_back(ms);
    if (!ok) ++errors_[method];
    calls_.push_back({start_s, method, ms, ok});
  }

  // Every call, in the order they ended.
  std::vector<Call> Calls() {
    std::lock_guard<std::mutex> lock(mu_);
    return calls_;
  }

  [[nodiscard]] std::size_t Count(const std::string& method) {
    std::lock_guard<std::mutex> lock(mu_);
    return samples_[method].size();
  }
  [[nodiscard]] int Errors(const std::string& method) {
    std::lock_guard<std::mutex> lock(mu_);
    return errors_[method];
  }

  // The q-quantile (0..1) of `method`'s latencies, ms; 0 when it has none.
  double Percentile(const std::string& method, double q) {
    std::lock_guard<std::mutex> lock(mu_);
    return Quantile(samples_[method], q);
  }

  std::vector<std::string> Methods() {
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<std::string> out;
    for (const auto& entry : samples_) out.push_back(entry.first);
    return out;
  }

  int Errors() {
    std::lock_guard<std::mutex> lock(mu_);
    int total = 0;
    for (const auto& entry : errors_) total += entry.second;
    return total;
  }

  // One line per method: calls, calls/s over `wall_s`, p50, p99, max, errors.
  void Print(double wall_s) {
    std::printf("%-16s %8s %10s %10s %10s %10s %8s\n", "method", "calls", "calls/s", "p50 ms",
                "p99 ms", "max ms", "errors");
    for (const std::string& method : Methods()) {
      const double p50 = Percentile(method, 0.5), p99 = Percentile(method, 0.99);
      std::lock_guard<std::mutex> lock(mu_);
      const std::vector<double>& v = samples_[method];
      std::printf("%-16s %8zu %10.1f %10.2f %10.2f %10.2f %8d\n", method.c_str(), v.size(),
                  static_cast<double>(v.size()) / wall_s, p50, p99, v.back(), errors_[method]);
    }
  }

 private:
  std::mutex mu_;
  std::map<std::string, std::vector<double>> samples_;
  std::map<std::string, int> errors_;
  std::vector<Call> calls_;
};

}  // namespace oaipp::bench
