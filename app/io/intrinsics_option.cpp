#include "io/intrinsics_option.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/error.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

Intrinsics make(double fx, double fy, double cx, double cy) {
  Intrinsics k;
  k.fx = fx;
  k.fy = fy;
  k.cx = cx;
  k.cy = cy;
  k.width = 640;
  k.height = 480;
  return k;
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
  return out;
}

// 4 numbers (fx fy cx cy) or 6 (plus width height) into a choice; `where` names the source.
IntrinsicsChoice from_numbers(const std::vector<double>& v, const std::string& where, std::string origin) {
  if (v.size() != 4 && v.size() != 6)
    throw Error(where + ": expected 4 numbers 'fx fy cx cy' or 6 'fx fy cx cy width height', got " +
                std::to_string(v.size()));
  IntrinsicsChoice choice;
  choice.intrinsics = make(v[0], v[1], v[2], v[3]);
  choice.size_known = v.size() == 6;
  if (choice.size_known) {
    if (v[4] != std::floor(v[4]) || v[5] != std::floor(v[5]) || v[4] < 1 || v[5] < 1 || v[4] > 1e5 || v[5] > 1e5)
      throw Error(where + ": image width and height must be positive integers");
    choice.intrinsics.width = static_cast<int>(v[4]);
    choice.intrinsics.height = static_cast<int>(v[5]);
  }
  choice.origin = std::move(origin);
  require_plausible(choice.intrinsics, where);
  return choice;
}

bool parse_number(const std::string& token, double& out) {
  std::istringstream ss(token);
  ss >> out;
  return ss && ss.peek() == std::char_traits<char>::eof() && std::isfinite(out);
}

}  // namespace

std::optional<Intrinsics> intrinsics_preset(std::string_view name) {
  const std::string n = lower(name);
  if (n == "fr1" || n == "freiburg1") return make(517.3, 516.5, 318.6, 255.3);
  if (n == "fr2" || n == "freiburg2") return make(520.9, 521.0, 325.1, 249.7);
  if (n == "fr3" || n == "freiburg3") return make(535.4, 539.2, 320.1, 247.6);
  if (n == "primesense") return make(525.0, 525.0, 319.5, 239.5);
  return std::nullopt;
}

std::optional<double> tum_depth_correction(std::string_view preset) {
  const std::string n = lower(preset);
  if (n == "fr1" || n == "freiburg1") return 1.035;
  if (n == "fr2" || n == "freiburg2") return 1.031;
  if (n == "fr3" || n == "freiburg3") return 1.0;
  return std::nullopt;
}

double tum_colour_readout_s(std::string_view preset) {
  const std::string n = lower(preset);
  return n == "fr1" || n == "freiburg1" ? 0.02 : 0.0;
}

void require_plausible_depth_correction(double depth_correction, const std::string& where) {
  if (!(depth_correction >= 0.5 && depth_correction <= 2.0))
    throw Error(where + ": --depth-correction must be between 0.5 and 2 (recorded depth / it = metric depth), got " +
                std::to_string(depth_correction));
}

std::string depth_correction_label(double depth_correction, const std::string& origin) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "depth / %.3f (", depth_correction);
  return buf + origin + ")";
}

IntrinsicsChoice read_calibration_file(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open calibration file " + path.string());
  std::vector<double> values;
  std::string line;
  while (std::getline(in, line)) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    std::string token;
    while (ss >> token) {
      double v = 0;
      if (!parse_number(token, v))
        throw Error("calibration file " + path.string() + ": '" + token + "' is not a number (expected 'fx fy cx cy [w h]')");
      values.push_back(v);
    }
  }
  return from_numbers(values, "calibration file " + path.string(), "calibration file " + path.string());
}

IntrinsicsChoice parse_intrinsics_option(const std::string& option) {
  const std::string where = "--intrinsics '" + option + "'";
  if (option.find(',') != std::string::npos) {
    std::vector<double> values;
    std::stringstream ss(option);
    std::string token;
    while (std::getline(ss, token, ',')) {
      token.erase(0, token.find_first_not_of(" \t"));
      token.erase(token.find_last_not_of(" \t") + 1);
      double v = 0;
      if (!parse_number(token, v)) throw Error(where + ": '" + token + "' is not a number");
      values.push_back(v);
    }
    return from_numbers(values, where, "--intrinsics " + option);
  }
  if (auto preset = intrinsics_preset(option)) {
    IntrinsicsChoice choice;
    choice.intrinsics = *preset;
    choice.size_known = true;
    choice.origin = lower(option) + " preset";
    if (tum_depth_correction(option)) choice.tum_preset = "fr" + std::string(1, lower(option).back());
    return choice;
  }
  std::error_code ec;
  if (!option.empty() && fs::is_regular_file(option, ec)) return read_calibration_file(option);
  throw Error(where + ": expected 'fx,fy,cx,cy[,w,h]', a preset (fr1, fr2, fr3, primesense) or a calibration file");
}

std::optional<std::string> guess_tum_preset(const fs::path& folder) {
  std::vector<std::string> parts;
  for (const auto& part : fs::absolute(folder).lexically_normal()) parts.push_back(lower(part.string()));
  // A name counts only as a whole word: "tum_fr2_desk" matches fr2, "fr23" and "xfr1" do not.
  const auto find_word = [](const std::string& s, const std::string& word) {
    for (auto pos = s.find(word); pos != std::string::npos; pos = s.find(word, pos + 1)) {
      const bool start_ok = pos == 0 || !std::isalnum(static_cast<unsigned char>(s[pos - 1]));
      const std::size_t end = pos + word.size();
      const bool end_ok = end == s.size() || !std::isdigit(static_cast<unsigned char>(s[end]));
      if (start_ok && end_ok) return true;
    }
    return false;
  };
  for (auto it = parts.rbegin(); it != parts.rend(); ++it) {
    for (const char* id : {"1", "2", "3"}) {
      if (find_word(*it, std::string("freiburg") + id) || find_word(*it, std::string("fr") + id))
        return std::string("fr") + id;
    }
  }
  return std::nullopt;
}

void require_plausible(const Intrinsics& k, const std::string& where) {
  if (!k.plausible()) throw Error(where + ": implausible intrinsics (" + k.to_string() + ")");
}

}  // namespace cofusion
