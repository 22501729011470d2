#include "util/progress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

namespace photometria {

ProgressReporter::ProgressReporter(std::ostream& out, bool terminal, double interval_seconds)
    : out_(out), terminal_(terminal), interval_(interval_seconds) {}

ProgressReporter::~ProgressReporter() { clear(); }

double ProgressReporter::seconds_left(double elapsed, double fraction) {
  if (!(fraction >= 0.01) || elapsed < 1.0) return -1.0;
  if (fraction >= 1.0) return 0.0;
  return elapsed * (1.0 - fraction) / fraction;
}

std::string ProgressReporter::format_duration(double seconds) {
  const long long s = std::llround(std::max(0.0, seconds));
  char text[48];
  if (s < 60) std::snprintf(text, sizeof text, "%lld s", s);
  else if (s < 3600) std::snprintf(text, sizeof text, "%lld min %lld s", s / 60, s % 60);
  else std::snprintf(text, sizeof text, "%lld h %02lld min", s / 3600, (s % 3600) / 60);
  return text;
}

void ProgressReporter::update(const std::string& stage, double fraction) {
  const Clock::time_point now = Clock::now();
  if (stage != stage_) {
    stage_ = stage;
    stage_start_ = last_shown_ = now;
    stage_done_shown_ = false;
  }
  fraction = std::min(1.0, std::max(0.0, fraction));
  const bool done = fraction >= 1.0;
  const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
  const double since_shown = std::chrono::duration<double>(now - last_shown_).count();
  if (terminal_) {
    // Redrawn at most every 0.2 s, and at the end of the stage (then cleared).
    if (!done && drawn_ && since_shown < 0.2) return;
  } else {
    // A line every interval; at the end of a stage one more, but only for a stage long enough
    // to have had a line (a short run prints nothing).
    if (done ? (stage_done_shown_ || elapsed < interval_) : since_shown < interval_) return;
    stage_done_shown_ = done;
  }
  last_shown_ = now;
  const double left = seconds_left(elapsed, fraction);
  const int percent = static_cast<int>(std::floor(100.0 * fraction));
  if (terminal_) {
    constexpr int kWidth = 20;
    const int filled = static_cast<int>(std::floor(kWidth * fraction));
    std::string line = "\r  " + stage_ + "  [" + std::string(size_t(filled), '#') +
                       std::string(size_t(kWidth - filled), '.') + "]  " + std::to_string(percent) + "%";
    if (left > 0) line += "  about " + format_duration(left) + " left";
    out_ << line << "    " << std::flush;
    drawn_ = true;
    if (done) clear();
    return;
  }
  out_ << "photometria: " << stage_ << " " << percent << "% (" << format_duration(elapsed) << ")";
  if (left > 0) out_ << ", about " << format_duration(left) << " left";
  out_ << "\n" << std::flush;
}

void ProgressReporter::clear() {
  if (!drawn_) return;
  out_ << "\r" << std::string(80, ' ') << "\r" << std::flush;
  drawn_ = false;
}

std::function<void(const std::string&, double)> ProgressReporter::callback() {
  return [this](const std::string& stage, double fraction) { update(stage, fraction); };
}

}  // namespace photometria
