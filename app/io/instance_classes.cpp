#include "io/instance_classes.h"

#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include "common/error.h"
#include "io/atomic_file.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

// A whole decimal number in [0, 65535], or nothing.
std::optional<std::uint16_t> parse_id(const std::string& token) {
  if (token.empty() || token.size() > 5 || token.find_first_not_of("0123456789") != std::string::npos) return {};
  const long value = std::stol(token);
  if (value > 65535) return {};
  return static_cast<std::uint16_t>(value);
}

}  // namespace

const std::string* InstanceClasses::find(std::uint16_t id) const {
  const auto it = name_by_id.find(id);
  return it == name_by_id.end() ? nullptr : &it->second;
}

bool is_class_name(const std::string& class_name) {
  if (class_name.empty()) return false;
  for (const char c : class_name)
    if (c <= ' ' || c > '~') return false;
  return true;
}

std::string class_name_token(const std::string& name) {
  if (name.empty()) return "unknown";
  std::string token = name;
  for (char& c : token)
    if (c <= ' ' || c > '~') c = '_';
  return token;
}

void require_class_name(const std::string& class_name, const std::string& what) {
  if (!is_class_name(class_name))
    throw Error(what + ": class name '" + class_name +
                "' must be one non-empty word of printable characters (use '_' for spaces)");
}

InstanceClasses read_instance_classes(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open class table " + path.string());
  InstanceClasses classes;
  classes.origin = path.string();
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    const std::string at = path.string() + ":" + std::to_string(line_no);
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);  // comment
    std::istringstream ss(line);
    std::vector<std::string> tokens;
    for (std::string t; ss >> t;) tokens.push_back(t);
    if (tokens.empty()) continue;
    if (tokens.size() != 2) throw Error(at + ": expected 'id class_name', got '" + line + "'");
    const auto id = parse_id(tokens[0]);
    if (!id) throw Error(at + ": '" + tokens[0] + "' is not a mask id (0-65535)");
    require_class_name(tokens[1], at);
    if (!classes.name_by_id.emplace(*id, tokens[1]).second)
      throw Error(at + ": id " + tokens[0] + " is listed twice");
  }
  if (in.bad()) throw Error("cannot read class table " + path.string());
  return classes;
}

std::string format_instance_classes(const InstanceClasses& classes) {
  std::string text = "# id class_name (instance ids of the masks beside this file)\n";
  for (const auto& [id, name] : classes.name_by_id) text += std::to_string(id) + " " + name + "\n";
  return text;
}

void write_instance_classes(const fs::path& path, const InstanceClasses& classes) {
  for (const auto& [id, name] : classes.name_by_id)
    require_class_name(name, "cannot write " + path.string() + ": id " + std::to_string(id));
  write_text_atomically(path, format_instance_classes(classes));
}

void require_mask_ids_classified(const cv::Mat& mask, const InstanceClasses& classes, const fs::path& mask_path) {
  if (mask.type() != CV_16UC1) throw Error("mask image " + mask_path.string() + " is not CV_16UC1");
  // One look-up per distinct id, not per pixel.
  std::vector<bool> checked(65536, false);
  checked[0] = true;  // 0 = no instance
  for (int y = 0; y < mask.rows; ++y) {
    const auto* row = mask.ptr<std::uint16_t>(y);
    for (int x = 0; x < mask.cols; ++x) {
      const std::uint16_t id = row[x];
      if (checked[id]) continue;
      if (!classes.find(id))
        throw Error("mask image " + mask_path.string() + ": id " + std::to_string(id) + " (pixel " +
                    std::to_string(x) + "," + std::to_string(y) + ") has no line in " + classes.origin);
      checked[id] = true;
    }
  }
}

}  // namespace cofusion
