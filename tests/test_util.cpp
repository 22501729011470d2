// The util folder: progress with the time left (util/progress.h) and errors (util/error.h).
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <thread>

#include "util/error.h"
#include "util/progress.h"

using namespace photometria;

TEST(Progress, TimeLeftIsTheStagesRateExtrapolated) {
  EXPECT_LT(ProgressReporter::seconds_left(0.5, 0.5), 0.0);     // under a second: too early
  EXPECT_LT(ProgressReporter::seconds_left(10.0, 0.005), 0.0);  // under 1%: too early
  EXPECT_DOUBLE_EQ(ProgressReporter::seconds_left(10.0, 0.25), 30.0);
  EXPECT_DOUBLE_EQ(ProgressReporter::seconds_left(4.0, 1.0), 0.0);
  EXPECT_EQ(ProgressReporter::format_duration(9.4), "9 s");
  EXPECT_EQ(ProgressReporter::format_duration(125), "2 min 5 s");
  EXPECT_EQ(ProgressReporter::format_duration(3600 + 180), "1 h 03 min");
}

// Off a terminal: one line per interval, a closing line per stage that had one, nothing at all
// for a short run.
TEST(Progress, LinesOffATerminal) {
  std::ostringstream quiet;
  {
    ProgressReporter p(quiet, false, 5.0);
    for (int k = 0; k <= 100; ++k) p.update("form factors", k / 100.0);
  }
  EXPECT_EQ(quiet.str(), "");  // well under the 5 s interval

  std::ostringstream out;
  {
    ProgressReporter p(out, false, 0.0);
    p.update("form factors", 0.5);
    p.update("form factors", 1.0);
    p.update("form factors", 1.0);  // the end is said once
    p.update("vertex gather", 0.25);
  }
  EXPECT_EQ(out.str(),
            "photometria: form factors 50% (0 s)\n"
            "photometria: form factors 100% (0 s)\n"
            "photometria: vertex gather 25% (0 s)\n");
}

// On a terminal: one line redrawn in place with a bar, the time left once known, cleared at the
// end of the stage.
TEST(Progress, BarOnATerminal) {
  std::ostringstream out;
  ProgressReporter p(out, true);
  p.update("form factors", 0.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  p.update("form factors", 0.5);
  const std::string drawn = out.str();
  EXPECT_NE(drawn.find("\r  form factors  [....................]  0%"), std::string::npos) << drawn;
  EXPECT_NE(drawn.find("\r  form factors  [##########..........]  50%  about "), std::string::npos) << drawn;
  p.update("form factors", 1.0);
  EXPECT_EQ(out.str().substr(out.str().size() - 82), "\r" + std::string(80, ' ') + "\r");
}

TEST(Errors, KindIsTheExitCode) {
  EXPECT_EQ(Error(ErrorKind::BadInput, "x").exit_code(), 1);
  EXPECT_EQ(Error(ErrorKind::Io, "x").exit_code(), 2);
  EXPECT_EQ(Error(ErrorKind::NotConverged, "x").exit_code(), 3);
  EXPECT_EQ(at("room.obj", 12), "room.obj:12");
  EXPECT_EQ(at("room.obj"), "room.obj");
}
