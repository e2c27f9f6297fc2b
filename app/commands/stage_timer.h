#pragma once
// Wall-clock timing of named pipeline stages: medians for the benchmark, means for summary.json.
#include <algorithm>
#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cofusion::commands {

// Median of `v` (0 when empty).
inline double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Whether time per frame grows over a run: the median of its first `window` frames and of its
// last `window` (time order; fewer when the run is shorter than 2 * window: half of it each).
struct FirstLastMedians {
  size_t window = 0;
  double first_ms = 0, last_ms = 0;
  double change() const { return first_ms > 0 ? last_ms / first_ms - 1 : 0; }  // +0.2 = 20 % slower
};
// nullopt for fewer than 2 frames.
inline std::optional<FirstLastMedians> first_last_medians(const std::vector<double>& frame_ms, size_t window) {
  if (frame_ms.size() < 2) return std::nullopt;
  FirstLastMedians m;
  m.window = std::min(window, frame_ms.size() / 2);
  const auto w = static_cast<std::ptrdiff_t>(m.window);
  m.first_ms = median_of({frame_ms.begin(), frame_ms.begin() + w});
  m.last_ms = median_of({frame_ms.end() - w, frame_ms.end()});
  return m;
}

class StageTimes {
 public:
  void add(const std::string& stage, double ms) {
    auto& v = samples_[stage];
    if (v.empty()) order_.push_back(stage);
    v.push_back(ms);
  }
  // Stages in first-seen order.
  const std::vector<std::string>& stages() const { return order_; }
  const std::vector<double>& samples(const std::string& stage) const { return samples_.at(stage); }
  double median(const std::string& stage) const { return median_of(samples_.at(stage)); }
  double mean(const std::string& stage) const {
    const auto& v = samples_.at(stage);
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0 : s / static_cast<double>(v.size());
  }

 private:
  std::map<std::string, std::vector<double>> samples_;
  std::vector<std::string> order_;
};

// Times a scope: `{ ScopedStage s(times, "upload"); ... }`.
class ScopedStage {
 public:
  ScopedStage(StageTimes& times, std::string stage)
      : times_(times), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}
  ~ScopedStage() {
    times_.add(stage_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count());
  }

 private:
  StageTimes& times_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace cofusion::commands
