// File and token helpers shared by the scene readers.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "scene/loaders.h"
#include "util/error.h"

namespace photometria::scene_detail {

bool is_readable_file(const std::string& path) {
  std::error_code ec;
  // Regular files only: ifstream opens directories, and a FIFO or /dev/zero would never end.
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  return std::ifstream(path).good();
}

std::string read_file_text(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
    throw_io("cannot open '" + path + "': not a regular file");
  if (!is_readable_file(path)) throw_io("cannot open '" + path + "'");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw_io("cannot read '" + path + "'");
  std::string s = text.str();
  // A UTF-8 byte order mark would glue itself to the first keyword.
  if (s.compare(0, 3, "\xEF\xBB\xBF") == 0) s.erase(0, 3);
  return s;
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string file_stem(const std::string& path) { return std::filesystem::path(path).stem().string(); }

std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i == line.size() || line[i] == '#') break;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    tokens.push_back(line.substr(i, j - i));
    i = j;
  }
  return tokens;
}

bool parse_number(std::string_view token, double& out) {
  // from_chars rejects a leading '+', which OBJ writers do emit.
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  if (ec == std::errc::result_out_of_range && ptr == end) {
    // A well-formed number beyond the double range: what strtod gives, ±inf on overflow (left
    // to the caller's finiteness check) or a (sub)normal or ±0 on underflow.
    out = std::strtod(std::string(token).c_str(), nullptr);
    return true;
  }
  return ec == std::errc() && ptr == end && !token.empty();
}

bool parse_integer(std::string_view token, long& out) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  const char* end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out);
  return ec == std::errc() && ptr == end && !token.empty();
}

std::string format_number(double x) {
  char buf[32];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, ptr) : std::string("?");
}

std::string in_quotes(std::string_view s) {
  // Built by appending: "'" + std::string(s) + "'" trips GCC 12's false -Wrestrict (bug 105651).
  std::string q;
  q.reserve(s.size() + 2);
  q.append(1, '\'').append(s).append(1, '\'');
  return q;
}

}  // namespace photometria::scene_detail
