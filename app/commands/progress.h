#pragma once
// The progress of `cofusion run` on its standard output. On a terminal: one line rewritten in
// place after every frame, fitted to the terminal's width, with the frame out of the total and the
// time left when the source knows its length; messages (events, a lost camera) scroll above it.
// Anywhere else (a pipe, a log file, a test): one plain line per frame, in the format scripts read.
#include <cstdio>
#include <optional>
#include <string>

namespace cofusion::commands {

struct ProgressInfo {
  int processed = 0;          // frames processed so far
  int read = 0;               // frames read from the source so far, skipped bad frames included
  std::optional<int> total;   // frames in the input, when the source knows
  double fps = 0;             // processed frames per second of wall-clock time since the start
  std::size_t models = 0;     // active models after the last frame
  unsigned surfels = 0;       // surfels in those models
  double inlier_ratio = 0;    // the camera tracking's share of inlier pixels (0..1)
  std::string camera_state;   // slam::CameraState as text: tracking, lost, recovered
};

// Seconds left for the frames after `read` of `total` at `fps`; nullopt when the total is unknown
// or the rate is not yet measured.
std::optional<double> eta_s(int read, std::optional<int> total, double fps);

// "0:07", "12:05", "1:02:03" (hours:minutes:seconds, rounded to the second).
std::string format_duration(double seconds);

// The terminal line: "frame 37/150  3.8 fps  ETA 0:30  models 3  camera tracking  surfels 41k"
// (frame 37, no ETA, when the total is unknown). Fields are dropped from the end until the line
// is shorter than `columns`, so that it never wraps (a wrapped line cannot be rewritten in place).
std::string status_line(const ProgressInfo& info, int columns);

// The plain line, unchanged from before the terminal line existed (scripts parse it):
// "frame 37  3.8 fps  models 3  surfels 41000  camera inliers 93%".
std::string plain_line(const ProgressInfo& info);

// The width of the terminal on `stream`, 80 when it is not a terminal or does not say.
int terminal_columns(std::FILE* stream);

// Writes progress and messages to stdout; on a terminal keeps the last status line at the bottom.
// Not thread safe: one thread prints.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool tty) : tty_(tty) {}
  bool tty() const { return tty_; }
  // After a frame: a terminal's line is rewritten; otherwise a plain line is printed.
  void update(const ProgressInfo& info);
  // One line of text to `stream`, above the status line (which the next update() draws again).
  void message(const std::string& text, std::FILE* stream = stdout);
  // Leaves the status line as it is and moves to the next line (before the run's final report).
  void finish();

 private:
  void clear_line();

  bool tty_;
  bool line_shown_ = false;  // a status line is on the screen, the cursor at its end
};

}  // namespace cofusion::commands
