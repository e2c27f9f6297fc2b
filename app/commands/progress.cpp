// Progress lines of `cofusion run`: formatting (pure, unit-tested) and the printer that keeps the
// terminal's status line in place.
#include "commands/progress.h"

#include <cmath>
#include <sys/ioctl.h>
#include <unistd.h>
#include <vector>

namespace cofusion::commands {
namespace {

std::string format(const char* fmt, auto... args) {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, fmt, args...);
  return buffer;
}

// 950, 41k, 1.2M: surfel counts short enough for the status line.
std::string short_count(unsigned n) {
  if (n < 10'000) return std::to_string(n);
  if (n < 1'000'000) return format("%uk", (n + 500) / 1000);
  return format("%.1fM", n / 1e6);
}

}  // namespace

std::optional<double> eta_s(int read, std::optional<int> total, double fps) {
  if (!total || !(fps > 0.0) || !std::isfinite(fps)) return std::nullopt;
  return std::max(0, *total - read) / fps;
}

std::string format_duration(double seconds) {
  const long s = std::lround(std::max(0.0, seconds));
  if (s >= 3600) return format("%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  return format("%ld:%02ld", s / 60, s % 60);
}

std::string status_line(const ProgressInfo& info, int columns) {
  // In the order shown, which is also the order of importance: the last ones go first when the
  // terminal is narrow.
  std::vector<std::string> fields;
  fields.push_back(info.total ? format("frame %d/%d", info.read, *info.total) : format("frame %d", info.read));
  fields.push_back(format("%.1f fps", info.fps));
  if (const auto eta = eta_s(info.read, info.total, info.fps)) fields.push_back("ETA " + format_duration(*eta));
  fields.push_back(format("models %zu", info.models));
  fields.push_back("camera " + info.camera_state);
  fields.push_back("surfels " + short_count(info.surfels));
  std::string line;
  for (const auto& field : fields) {
    const std::string next = line.empty() ? field : line + "  " + field;
    if (static_cast<int>(next.size()) >= columns) break;
    line = next;
  }
  return line;
}

std::string plain_line(const ProgressInfo& info) {
  return format("frame %d  %.1f fps  models %zu  surfels %u  camera inliers %.0f%%", info.processed, info.fps,
                info.models, info.surfels, 100.0 * info.inlier_ratio);
}

int terminal_columns(std::FILE* stream) {
  winsize size{};
  if (::ioctl(::fileno(stream), TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
  return 80;
}

void ProgressPrinter::update(const ProgressInfo& info) {
  if (tty_) {
    // Carriage return, the line, then erase what a longer earlier line left to its right.
    std::printf("\r%s\033[K", status_line(info, terminal_columns(stdout)).c_str());
    line_shown_ = true;
  } else {
    std::printf("%s\n", plain_line(info).c_str());
  }
  std::fflush(stdout);
}

void ProgressPrinter::message(const std::string& text, std::FILE* stream) {
  clear_line();
  std::fprintf(stream, "%s\n", text.c_str());
  std::fflush(stream);
}

void ProgressPrinter::finish() {
  if (line_shown_) std::printf("\n");
  line_shown_ = false;
  std::fflush(stdout);
}

void ProgressPrinter::clear_line() {
  if (!line_shown_) return;
  std::printf("\r\033[K");
  std::fflush(stdout);
  line_shown_ = false;
}

}  // namespace cofusion::commands
