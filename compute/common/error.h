#pragma once
// The one exception type the project throws for bad input, bad configuration and failed
// device calls. Messages name the file, frame or call and say what is wrong.
#include <stdexcept>
#include <string>

namespace cofusion {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace cofusion
