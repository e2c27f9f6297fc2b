#include "gpu/kernel_profile.h"

namespace cofusion::gpu {

void KernelProfile::add(const std::string& key, double ms) {
  std::lock_guard lock(mutex_);
  Entry& e = entries_[key];
  e.total_ms += ms;
  ++e.calls;
}

std::map<std::string, KernelProfile::Entry> KernelProfile::take() {
  std::lock_guard lock(mutex_);
  std::map<std::string, Entry> out;
  out.swap(entries_);
  return out;
}

}  // namespace cofusion::gpu
