#pragma once
// GPU time per kernel, from timestamp queries. While a KernelProfile is attached to a Context,
// every dispatch a Stream records is bracketed by two timestamps; when the Stream sees the
// submission finished it reads them back and adds the interval to the profile under
// "<stream's profile group>: <pipeline name> <command list's label>". Off by default: the queries
// cost a little on every dispatch.
//
// On a GPU that runs dispatches without a barrier between them concurrently, the intervals
// overlap and their sum exceeds the wall time; on lavapipe dispatches run one after another.
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

namespace cofusion::gpu {

class KernelProfile {
 public:
  struct Entry {
    double total_ms = 0;
    uint64_t calls = 0;
  };
  // Thread-safe: streams on several threads add their results.
  void add(const std::string& key, double ms);
  // Everything recorded since the last take(), keyed as above; the profile is empty afterwards.
  std::map<std::string, Entry> take();

 private:
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

}  // namespace cofusion::gpu
