#pragma once
// Wall-clock timing of named pipeline stages: medians for the benchmark, means for summary.json.
#include <algorithm>
#include <chrono>
#include <map>
#include <string>
#include <vector>

namespace cofusion::commands {

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
  double median(const std::string& stage) const {
    auto v = samples_.at(stage);
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  }
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
