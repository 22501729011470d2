// Checks text OFF, PLY and STL before OpenMesh reads them. OpenMesh's text readers read "nan",
// "abc" or a truncated file as zeros or uninitialised values and still report success, so the
// numbers and face indices are checked here, with the file and line in every message. Binary
// variants are left to OpenMesh (and to the finite check after reading).
#include <cmath>
#include <cstdint>
#include <cstring>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {
namespace {

using Tokens = std::vector<std::string_view>;

// Non-empty, non-comment lines with their numbers.
struct Line {
  long number;
  Tokens tokens;
};

std::vector<Line> content_lines(std::string_view text) {
  std::vector<Line> lines;
  for_each_line(text, [&](long n, std::string_view line) {
    Tokens t = split_tokens(line);
    if (!t.empty()) lines.push_back({n, std::move(t)});
  });
  return lines;
}

class Checker {
 public:
  explicit Checker(const std::string& path) : path_(path) {}

  [[noreturn]] void fail(long line, const std::string& what) const { throw_bad_input(at(path_, line) + ": " + what); }

  // `vertex` is the 0-based vertex number when known (OFF, PLY), -1 otherwise (STL).
  void coordinate(long line, std::string_view token, long vertex = -1) const {
    const std::string which = vertex < 0 ? "vertex" : "vertex " + std::to_string(vertex);
    double x = 0;
    if (!parse_number(token, x)) fail(line, "bad " + which + " coordinate " + in_quotes(token));
    if (!std::isfinite(x)) fail(line, which + " coordinate " + in_quotes(token) + " is not a finite number");
  }

  void vertex(const Line& l, long index) const {
    if (l.tokens.size() < 3) fail(l.number, "vertex needs 3 coordinates, got " + std::to_string(l.tokens.size()));
    for (std::string_view t : l.tokens) coordinate(l.number, t, index);
  }

  long integer(long line, std::string_view token, const char* what) const {
    long i = 0;
    if (!parse_integer(token, i)) fail(line, std::string("bad ") + what + " " + in_quotes(token));
    return i;
  }

  // "k i_1 ... i_k [more]" with 0-based indices below `vertices`.
  void face(const Line& l, long vertices) const {
    const long k = integer(l.number, l.tokens[0], "face vertex count");
    if (k < 3) fail(l.number, "face with " + std::to_string(k) + " vertices (a face needs at least 3)");
    if (static_cast<long>(l.tokens.size()) < k + 1)
      fail(l.number,
           "face lists " + std::to_string(l.tokens.size() - 1) + " of its " + std::to_string(k) + " vertices");
    for (long j = 1; j <= k; ++j) {
      const long i = integer(l.number, l.tokens[static_cast<size_t>(j)], "face index");
      if (i < 0 || i >= vertices)
        fail(l.number, "face index " + std::to_string(i) + " out of range (" + std::to_string(vertices) + " vertices)");
    }
  }

 private:
  const std::string& path_;
};

void check_off(const std::string& path, std::string_view text) {
  const Checker check(path);
  // OpenMesh's OFF reader reads a file with '#' comments as an empty mesh and reports success.
  for_each_line(text, [&](long n, std::string_view line) {
    if (line.find('#') != std::string_view::npos) check.fail(n, "'#' comments are not supported in OFF files");
  });
  const std::vector<Line> lines = content_lines(text);
  if (lines.empty()) throw_bad_input(at(path) + ": empty file");
  const Tokens& header = lines[0].tokens;
  const std::string_view kind = header[0];
  // Binary OFF and the rarer nOFF / 4OFF layouts are left to OpenMesh.
  if (kind.size() < 3 || kind.substr(kind.size() - 3) != "OFF") check.fail(lines[0].number, "not an OFF file");
  if (kind[0] == 'n' || kind[0] == '4' || (header.size() > 1 && header[1] == "BINARY")) return;

  // The counts may follow the keyword on the same line.
  size_t next = 1;
  Tokens counts(header.begin() + 1, header.end());
  long counts_line = lines[0].number;
  if (counts.empty()) {
    if (lines.size() < 2) throw_bad_input(at(path) + ": no vertex and face counts");
    counts = lines[1].tokens;
    counts_line = lines[1].number;
    next = 2;
  }
  if (counts.size() < 2) check.fail(counts_line, "expected vertex and face counts");
  const long nv = check.integer(counts_line, counts[0], "vertex count");
  const long nf = check.integer(counts_line, counts[1], "face count");
  if (nv < 0 || nf < 0) check.fail(counts_line, "negative vertex or face count");
  if (static_cast<long>(lines.size() - next) < nv + nf)
    throw_bad_input(at(path) + ": file ends early (expected " + std::to_string(nv) + " vertices and " +
                    std::to_string(nf) + " faces)");
  for (long i = 0; i < nv; ++i) check.vertex(lines[next + static_cast<size_t>(i)], i);
  for (long i = 0; i < nf; ++i) check.face(lines[next + static_cast<size_t>(nv + i)], nv);
}

// ASCII PLY: one element instance per data line, in header order.
void check_ply(const std::string& path, std::string_view text) {
  const Checker check(path);
  const std::vector<Line> lines = content_lines(text);
  std::vector<std::pair<std::string, long>> elements;
  size_t i = 0;
  bool ascii = false;
  for (; i < lines.size() && lines[i].tokens[0] != "end_header"; ++i) {
    const Tokens& t = lines[i].tokens;
    if (t[0] == "format") ascii = t.size() > 1 && t[1] == "ascii";
    if (t[0] == "element" && t.size() > 2)
      elements.emplace_back(t[1], check.integer(lines[i].number, t[2], "element count"));
  }
  if (!ascii || i == lines.size()) return;  // binary, or a header OpenMesh will refuse
  ++i;
  long vertices = 0;
  for (const auto& [name, count] : elements) {
    if (static_cast<long>(lines.size() - i) < count)
      throw_bad_input(at(path) + ": file ends early (expected " + std::to_string(count) + " " + name + " lines)");
    for (long k = 0; k < count; ++k, ++i) {
      if (name == "vertex") check.vertex(lines[i], k);
      else if (name == "face") check.face(lines[i], vertices);
    }
    if (name == "vertex") vertices = count;
  }
}

// Binary STL: an 80-byte header, a 4-byte triangle count and 50 bytes per triangle.
bool is_binary_stl(std::string_view text) {
  if (text.size() < 84) return false;
  std::uint32_t n = 0;
  std::memcpy(&n, text.data() + 80, 4);
  return text.size() == 84 + 50 * static_cast<size_t>(n);
}

void check_stl(const std::string& path, std::string_view text) {
  if (is_binary_stl(text)) return;
  const Checker check(path);
  for (const Line& l : content_lines(text)) {
    if (l.tokens[0] != "vertex") continue;
    if (l.tokens.size() != 4)
      check.fail(l.number, "vertex needs 3 coordinates, got " + std::to_string(l.tokens.size() - 1));
    for (size_t k = 1; k < 4; ++k) check.coordinate(l.number, l.tokens[k]);
  }
}

}  // namespace

void check_mesh_text(const std::string& path, const std::string& extension) {
  if (extension != ".off" && extension != ".ply" && extension != ".stl") return;
  const std::string text = read_file_text(path);
  if (extension == ".off") check_off(path, text);
  else if (extension == ".ply") check_ply(path, text);
  else check_stl(path, text);
}

}  // namespace photometria::scene_detail
