// Faults a real machine has, made to happen for real, through the command line: a full disk (a
// small tmpfs, when the test may mount one, i.e. runs as root with CAP_SYS_ADMIN) and a file-size
// limit (RLIMIT_FSIZE, what `ulimit -f` sets; always), SIGTERM in the middle of the work, an
// address-space limit (RLIMIT_AS) against a huge patch count, and numeric options out of range.
//
// What must hold every time: the documented exit code, one line on stderr naming the path or the
// option, the earlier result untouched, and no temporary file left behind.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <omp.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/statvfs.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "scratch_dir.h"

namespace fs = std::filesystem;

// AddressSanitizer, by GCC's macro or Clang's feature test (CI builds the sanitized tests with Clang).
#if defined(__SANITIZE_ADDRESS__)
#define PHOTOMETRIA_TESTS_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PHOTOMETRIA_TESTS_UNDER_ASAN 1
#endif
#endif

namespace {

const std::string kMeshes = std::string(PHOTOMETRIA_SOURCE_DIR) + "/meshes/";

struct Outcome {
  int exit_code = -1;  // -1 when killed by a signal
  int signal = 0;      // the signal that ended it, 0 when it exited
  std::string err;     // everything on stderr
};

struct Limits {
  std::optional<rlim_t> file_size;      // RLIMIT_FSIZE, bytes
  std::optional<rlim_t> address_space;  // RLIMIT_AS, bytes
  std::string stdout_path = "/dev/null";
};

// Starts photometria with `args` under `limits`; stderr comes back through a pipe (a file
// would be subject to the file-size limit itself). SIGXFSZ is left at its default in the child:
// photometria must ignore it itself.
pid_t start(const std::vector<std::string>& args, const Limits& limits, int& err_fd) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) throw std::runtime_error("pipe");
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork");
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::signal(SIGINT, SIG_DFL);
    ::dup2(pipe_fds[1], STDERR_FILENO);
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    const int out = ::open(limits.stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out < 0) ::_exit(126);
    ::dup2(out, STDOUT_FILENO);
    ::close(out);
    if (limits.file_size) {
      const rlimit r{*limits.file_size, *limits.file_size};
      ::setrlimit(RLIMIT_FSIZE, &r);
    }
    if (limits.address_space) {
      const rlimit r{*limits.address_space, *limits.address_space};
      ::setrlimit(RLIMIT_AS, &r);
    }
    std::vector<char*> argv{const_cast<char*>(PHOTOMETRIA_BINARY)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(PHOTOMETRIA_BINARY, argv.data());
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  err_fd = pipe_fds[0];
  return pid;
}

Outcome finish(pid_t pid, int err_fd) {
  Outcome o;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(err_fd, buf, sizeof buf)) > 0) o.err.append(buf, size_t(n));
  ::close(err_fd);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status)) o.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) o.signal = WTERMSIG(status);
  return o;
}

Outcome run(const std::vector<std::string>& args, const Limits& limits = {}) {
  int err_fd = -1;
  const pid_t pid = start(args, limits, err_fd);
  return finish(pid, err_fd);
}

// stderr without photometria's load warnings (the shipped Cornell box has two).
std::string errors_only(const std::string& err) {
  std::istringstream in(err);
  std::string line, out;
  while (std::getline(in, line))
    if (line.find("photometria: warning:") != 0) out += line + "\n";
  return out;
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

std::map<std::string, std::string> contents(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::directory_iterator(dir)) m[e.path().filename().string()] = read(e.path());
  return m;
}

// A small tmpfs of `bytes`, mounted on a fresh folder for the life of the object. mounted() is
// false where the test may not mount (no CAP_SYS_ADMIN); the tmpfs cases then skip, the
// file-size-limit cases still run.
class SmallDisk {
 public:
  explicit SmallDisk(size_t bytes) : dir_(test_scratch::fresh_dir("photometria_disk_")) {
    const std::string options = "size=" + std::to_string(bytes);
    mounted_ = ::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) == 0;
    if (!mounted_) why_ = std::strerror(errno);
  }
  ~SmallDisk() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  bool mounted() const { return mounted_; }
  const std::string& why() const { return why_; }
  const fs::path& dir() const { return dir_; }
  // Fills the disk with the file "filler" until at most `free_bytes` are left (0: full).
  void fill_leaving(size_t free_bytes) const {
    struct statvfs st {};
    ::statvfs(dir_.c_str(), &st);
    const size_t avail = size_t(st.f_bavail) * st.f_frsize;
    std::ofstream f(dir_ / "filler", std::ios::binary);
    const std::string block(4096, 'x');
    size_t written = 0;
    // Pages of 4 KiB: what is left is free_bytes rounded down to a page.
    while ((free_bytes == 0 || avail - written > free_bytes) && f.write(block.data(), block.size())) {
      f.flush();
      written += block.size();
    }
  }

 private:
  fs::path dir_;
  bool mounted_ = false;
  std::string why_;
};

// How the write fails.
enum class Fault { FullDisk, FileSizeLimit };
std::string fault_name(const testing::TestParamInfo<Fault>& info) {
  return info.param == Fault::FullDisk ? "FullDisk" : "FileSizeLimit";
}

// A place to write into where at most `room` bytes can be written: a tmpfs with `room` free, or
// a fresh folder with RLIMIT_FSIZE = room (then every file the run writes is limited to it).
class Cramped {
 public:
  Cramped(Fault fault, size_t room) : fault_(fault), room_(room) {
    if (fault == Fault::FullDisk) {
      disk_.emplace(1 << 20);
      dir_ = disk_->dir();
    } else {
      dir_ = test_scratch::fresh_dir("photometria_fsize_");
    }
  }
  ~Cramped() {
    if (fault_ == Fault::FileSizeLimit) fs::remove_all(dir_);
  }
  // False (with the reason) when the full-disk case cannot be made here.
  bool available(std::string& why) const {
    if (fault_ == Fault::FileSizeLimit) return true;
    why = disk_->why();
    return disk_->mounted();
  }
  // Call after the earlier results are in place: then the room is what is left.
  Limits limits(const std::string& stdout_path = "/dev/null") const {
    if (fault_ == Fault::FullDisk) disk_->fill_leaving(room_);
    Limits l;
    l.stdout_path = stdout_path;
    if (fault_ == Fault::FileSizeLimit) l.file_size = room_;
    return l;
  }
  const fs::path& dir() const { return dir_; }

 private:
  Fault fault_;
  size_t room_;
  std::optional<SmallDisk> disk_;  // FullDisk only
  fs::path dir_;
};

class WriteFaults : public ::testing::TestWithParam<Fault> {
 protected:
  // One line on stderr (besides load warnings), exit 2, naming `what`; the folder holds exactly
  // `before` (plus the tmpfs filler) afterwards: earlier files untouched, no temporary file.
  static void expect_io_failure(const Outcome& o, const std::string& what, const fs::path& dir,
                                std::map<std::string, std::string> before) {
    EXPECT_EQ(o.exit_code, 2) << o.err;
    const std::string err = errors_only(o.err);
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_EQ(err.rfind("photometria: cannot write " + what, 0), 0u) << err;
    std::map<std::string, std::string> after = contents(dir);
    after.erase("filler");
    before.erase("filler");
    EXPECT_EQ(after, before);
  }
};

#define REQUIRE_FAULT(cramped)                                                             \
  do {                                                                                     \
    std::string why_;                                                                      \
    if (!(cramped).available(why_)) GTEST_SKIP() << "cannot mount a tmpfs here: " << why_; \
  } while (0)

// The earlier .vtu stays when the new one does not fit (the Cornell box's is 160 KB).
TEST_P(WriteFaults, SolveKeepsTheEarlierResult) {
  const Cramped c(GetParam(), 32 << 10);
  REQUIRE_FAULT(c);
  const fs::path out = c.dir() / "cornell.vtu";
  write(out, "an earlier result\n");
  const auto before = contents(c.dir());
  const Outcome o = run({"solve", kMeshes + "cornell_box.obj", "-o", out.string(), "--quiet"}, c.limits());
  expect_io_failure(o, "'" + out.string() + "'", c.dir(), before);
}

// viewfactors: the CSV (18 faces × 18, 17 digits: 4 KB) does not fit in 2 KiB.
TEST_P(WriteFaults, ViewFactorsKeepTheEarlierMatrix) {
  const Cramped c(GetParam(), 2 << 10);
  REQUIRE_FAULT(c);
  const fs::path out = c.dir() / "vf.csv";
  write(out, "an earlier matrix\n");
  const auto before = contents(c.dir());
  // --quiet: under the sanitizers on a slow machine the fill takes seconds, and its progress
  // line would precede the one error line this test is about.
  const Outcome o =
      run({"viewfactors", kMeshes + "cornell_box.obj", "--by", "face", "-o", out.string(), "--quiet"}, c.limits());
  expect_io_failure(o, "'" + out.string() + "'", c.dir(), before);
}

// Sparse rows streamed while they are filled (the cube at 600 patches: the "# surface" lines take
// 21 KB, the rows over 2 MB) stop at the first write that fails, in the middle of the fill.
TEST_P(WriteFaults, ViewFactorsStreamedStopAtTheFirstFailedWrite) {
  const Cramped c(GetParam(), 64 << 10);
  REQUIRE_FAULT(c);
  const fs::path out = c.dir() / "vf.sparse";
  write(out, "an earlier matrix\n");
  const auto before = contents(c.dir());
  const Outcome o = run({"viewfactors", kMeshes + "furnace_cube.obj", "--by", "patch", "--max-edge", "0.1", "--format",
                         "sparse", "--stream", "yes", "--quiet", "-o", out.string()},
                        c.limits());
  expect_io_failure(o, "'" + out.string() + "'", c.dir(), before);
}

// A summary on standard output that does not reach the disk is an error too (formfactor prints
// only there: 300 lines, 30 KB, into 4 KiB).
TEST_P(WriteFaults, FormFactorSeesItsStandardOutputFail) {
  const Cramped c(GetParam(), 4 << 10);
  REQUIRE_FAULT(c);
  const fs::path queries = test_scratch::process_dir("photometria_faults_") / "queries.json";
  std::string text = "{\"queries\": [";
  for (int k = 0; k < 300; ++k)
    text += std::string(k ? "," : "") + "{\"id\": \"q" + std::to_string(k) +
            "\", \"point\": [0,0,0], \"normal\": [0,0,1], \"polygon\": [[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]]}";
  write(queries, text + "]}");
  const fs::path out = c.dir() / "factors.jsonl";
  const Outcome o = run({"formfactor", queries.string()}, c.limits(out.string()));
  EXPECT_EQ(o.exit_code, 2) << o.err;
  EXPECT_EQ(o.err.rfind("photometria: cannot write standard output: ", 0), 0u) << o.err;
  EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
}

// validate --report: the CSV and the table fit, the plot (88 KB) does not; all three earlier
// files stay as they were (the report is all or nothing) and gnuplot's data and script go too.
TEST_P(WriteFaults, ValidateReportIsAllOrNothing) {
  const Cramped c(GetParam(), 32 << 10);
  REQUIRE_FAULT(c);
  for (const char* name : {"validation.csv", "validation_table.md", "error_vs_time.png"})
    write(c.dir() / name, std::string("an earlier ") + name + "\n");
  const auto before = contents(c.dir());
  const Outcome o = run({"validate", "--quick", "--report", c.dir().string()}, c.limits());
  expect_io_failure(o, "'" + (c.dir() / "error_vs_time.png").string() + "'", c.dir(), before);
}

// bench --csv with no room at all.
TEST_P(WriteFaults, BenchKeepsTheEarlierCsv) {
#if defined(KMP_VERSION_MAJOR)
  // LLVM's OpenMP runtime (Clang's) sizes a registration file in /dev/shm when its first parallel
  // region starts and ends the process when RLIMIT_FSIZE forbids it, before the bench writes
  // anything; GCC's runtime, which the shipped build uses, keeps no such file.
  if (GetParam() == Fault::FileSizeLimit) GTEST_SKIP() << "LLVM's OpenMP runtime cannot start under RLIMIT_FSIZE 0";
#endif
  const Cramped c(GetParam(), 0);
  REQUIRE_FAULT(c);
  const fs::path out = c.dir() / "bench.csv";
  write(out, "an earlier bench\n");
  const auto before = contents(c.dir());
  const Outcome o = run({"bench", "--quick", "--only", "cube n=8 solve", "--csv", out.string()}, c.limits());
  // bench reports progress on stderr: the error is its last line.
  std::string err = o.err;
  std::string last = err.substr(err.rfind('\n', err.size() - 2) + 1);
  EXPECT_EQ(o.exit_code, 2) << o.err;
  EXPECT_EQ(last.rfind("photometria: cannot write '" + out.string() + "'", 0), 0u) << o.err;
  std::map<std::string, std::string> after = contents(c.dir());
  after.erase("filler");
  auto expected = before;
  expected.erase("filler");
  EXPECT_EQ(after, expected);
}

INSTANTIATE_TEST_SUITE_P(, WriteFaults, ::testing::Values(Fault::FullDisk, Fault::FileSizeLimit), fault_name);

// ----- SIGTERM in the middle of the work ------------------------------------------------------------

// Starts a long run writing into `dir`, waits until its temporary file exists (opened before
// the work starts) and a moment more, stops it with SIGTERM and checks that it died of the
// signal leaving `dir` as it was.
void interrupt(const std::vector<std::string>& args, const fs::path& dir) {
  const auto before = contents(dir);
  int err_fd = -1;
  Limits limits;
  const pid_t pid = start(args, limits, err_fd);
  const std::string tag = ".tmp-" + std::to_string(pid);
  auto temporary_exists = [&] {
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().filename().string().find(tag) != std::string::npos) return true;
    return false;
  };
  for (int i = 0; i < 2000 && !temporary_exists(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_TRUE(temporary_exists()) << "the run did not start";
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  ::kill(pid, SIGTERM);
  const Outcome o = finish(pid, err_fd);
  EXPECT_EQ(o.signal, SIGTERM) << "exit " << o.exit_code << ": " << o.err;
  EXPECT_EQ(contents(dir), before);
}

class Interrupted : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test_scratch::fresh_dir("photometria_term_"); }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(Interrupted, ViewFactorsInTheFill) {
  write(dir_ / "vf.csv", "an earlier matrix\n");
  interrupt({"viewfactors", kMeshes + "room_with_table.obj", "--by", "patch", "--max-edge", "0.05", "--threads", "1",
             "-o", (dir_ / "vf.csv").string()},
            dir_);
}

TEST_F(Interrupted, ValidateReport) {
  for (const char* name : {"validation.csv", "validation_table.md", "error_vs_time.png"})
    write(dir_ / name, std::string("an earlier ") + name + "\n");
  interrupt({"validate", "--report", dir_.string()}, dir_);
}

TEST_F(Interrupted, BenchCsv) {
  write(dir_ / "bench.csv", "an earlier bench\n");
  interrupt({"bench", "--threads", "1", "--csv", (dir_ / "bench.csv").string()}, dir_);
}

// ----- memory -----------------------------------------------------------------------------------

// A typo in --max-edge (1e-3 for 1e-1: 47 million patches in the Cornell box) is refused from
// the count, before patching: under a 2 GiB address space the run ends with the one-line
// refusal (exit 1), where allocating the patches would end in std::bad_alloc (exit 4).
// AddressSanitizer reserves terabytes of address space at start, so this runs without it.
TEST(MemoryFaults, HugePatchCountIsRefusedBeforeAllocating) {
#if defined(PHOTOMETRIA_TESTS_UNDER_ASAN)
  GTEST_SKIP() << "RLIMIT_AS cannot be combined with AddressSanitizer's shadow memory";
#endif
  Limits limits;
  limits.address_space = rlim_t(2) << 30;
  const fs::path dir = test_scratch::process_dir("photometria_faults_");
  for (const std::string command : {"solve", "viewfactors"}) {
    std::vector<std::string> args = {command, kMeshes + "cornell_box.obj",         "--max-edge", "1e-3",
                                     "-o",    (dir / ("huge_" + command)).string()};
    const Outcome o = run(args, limits);
    EXPECT_EQ(o.exit_code, 1) << o.err;
    const std::string err = errors_only(o.err);
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    EXPECT_NE(err.find("47,467,975 patches"), std::string::npos) << err;
    EXPECT_NE(err.find("--max-edge"), std::string::npos) << err;
    // And against an explicit limit that the patching alone would exceed.
    args.insert(args.end(), {"--max-memory", "64M"});
    args[3] = "2e-3";
    const Outcome limited = run(args, limits);
    EXPECT_EQ(limited.exit_code, 1) << limited.err;
    EXPECT_NE(limited.err.find("--max-memory is 64 MiB"), std::string::npos) << limited.err;
  }
}

// ----- numeric options --------------------------------------------------------------------------

// Every numeric option of every subcommand refuses values out of range, NaN and infinities with
// one line naming the option and the value (exit 1), before any work.
TEST(OptionFaults, EveryNumericOptionIsRangeChecked) {
  const std::string scene = kMeshes + "cornell_box.obj";
  const std::string out = (test_scratch::process_dir("photometria_faults_") / "never.out").string();
  struct Case {
    std::vector<std::string> command;
    std::string option;
    std::vector<std::string> bad;
  };
  const std::vector<std::string> solve = {"solve", scene, "-o", out};
  const std::vector<std::string> viewfactors = {"viewfactors", scene, "-o", out};
  const std::vector<std::string> bench = {"bench", "--quick"};
  const std::vector<Case> cases = {
      {solve, "--max-edge", {"-1", "nan", "inf", "1e999", "abc"}},
      {solve, "--max-area", {"-0.5", "nan", "inf"}},
      {solve, "--quadrature", {"0", "17", "-2", "1.5"}},
      {solve, "--accuracy", {"-0.1", "1", "nan"}},
      {solve, "--crease-angle", {"-5", "180", "200", "abc", "nan"}},
      {solve, "--rays", {"0", "-5", "99999999999", "abc", "auto5", "1.5"}},
      {solve, "--seed", {"-1", "x"}},
      {solve, "--tolerance", {"0", "-1e-8", "nan", "inf"}},
      {solve, "--max-iterations", {"0", "-10"}},
      {solve, "--threads", {"-3", "100000", "nan"}},
      {viewfactors, "--threshold", {"-1e-9", "2", "nan"}},
      {viewfactors, "--max-edge", {"-1", "nan", "inf"}},
      {viewfactors, "--accuracy", {"0", "1", "-1", "nan"}},
      {viewfactors, "--rays", {"0", "-1", "Auto"}},
      {viewfactors, "--threads", {"-3"}},
      {bench, "--threads", {"-3", "nan"}},
      {bench, "--max-patches", {"-1", "1e3"}},
  };
  for (const Case& c : cases)
    for (const std::string& value : c.bad) {
      std::vector<std::string> args = c.command;
      args.insert(args.end(), {c.option, value});
      const Outcome o = run(args);
      EXPECT_EQ(o.exit_code, 1) << c.option << " " << value << ": " << o.err;
      EXPECT_EQ(std::count(o.err.begin(), o.err.end(), '\n'), 1) << o.err;
      EXPECT_EQ(o.err.rfind("photometria: " + c.option + ": " + value + " is not ", 0), 0u) << o.err;
      EXPECT_FALSE(fs::exists(out));
    }
}

}  // namespace
