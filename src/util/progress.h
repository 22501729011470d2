// Progress of a long run on stderr, with an estimate of the time left.
//
// A run goes through named stages ("form factors", "vertex gather", ...), each reporting the
// fraction done. On a terminal one line is redrawn in place, at most every 0.2 s:
//     form factors  [##########..........]  52%  about 9 s left
// Elsewhere (a log file, CI) one line every `interval_seconds`, and one when a stage ends:
//     photometria: form factors 52% (10.2 s), about 9 s left
// The estimate for a stage is its elapsed time × (1 − f) / f, given once the stage has run for
// 1 s and is at least 1% done (earlier it would mostly be noise). It is the time left in the
// current stage: the stages of a run differ too much in cost to extrapolate from one to the
// next.
//
// update() may be called often and from one thread at a time (the fill and the gather call it
// from their first thread); it does nothing between redraws but read the clock.
#pragma once

#include <chrono>
#include <functional>
#include <iosfwd>
#include <string>

namespace photometria {

class ProgressReporter {
 public:
  // out: where to write (std::cerr); terminal: redraw one line (a TTY) or print lines.
  ProgressReporter(std::ostream& out, bool terminal, double interval_seconds = 5.0);
  ~ProgressReporter();  // clears a terminal line left drawn
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  // `stage` is `fraction` (0..1) done; a new stage name starts a new stage (and its clock).
  void update(const std::string& stage, double fraction);
  // Clears the terminal line (before other output on stderr).
  void clear();

  // update() as a std::function, for the library's progress callbacks.
  std::function<void(const std::string&, double)> callback();

  // The estimate update() shows: seconds left after `elapsed` seconds at `fraction` done, or a
  // negative number when it is too early to say.
  static double seconds_left(double elapsed, double fraction);
  // "9 s", "2 min 5 s", "1 h 03 min".
  static std::string format_duration(double seconds);

 private:
  using Clock = std::chrono::steady_clock;
  std::ostream& out_;
  bool terminal_;
  double interval_;
  std::string stage_;
  Clock::time_point stage_start_, last_shown_;
  bool drawn_ = false;             // a terminal line is on screen
  bool stage_done_shown_ = false;  // the stage's closing line was printed
};

}  // namespace photometria
