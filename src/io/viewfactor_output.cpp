// View-factor matrix writers (viewfactor_output.h).
#include "io/viewfactor_output.h"

#include <omp.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <memory>
#include <optional>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/direct_append.h"
#include "io/shortest_decimal.h"
#include "util/error.h"

namespace photometria {

namespace {

// The shortest decimal that reads back as the same double (io/shortest_decimal.h: the characters
// of std::to_chars without a precision, round-trip exact, at most 17 significant digits).
void append_shortest(std::string& out, double v) {
  char buf[kShortestDecimalMaxChars];
  out.append(buf, size_t(write_shortest(buf, v) - buf));
}

std::string shortest(double v) {
  std::string s;
  append_shortest(s, v);
  return s;
}

// printf's "%.<precision>f" (fixed) or "%.<precision>g" (general) of v, without printf's locale
// and format parsing: std::to_chars with a precision rounds the exact binary value as printf does.
void append_printf_like(std::string& out, double v, std::chars_format format, int precision) {
  char buf[64];
  out.append(buf, size_t(std::to_chars(buf, buf + sizeof buf, v, format, precision).ptr - buf));
}

// Rows 0 .. rows-1 formatted by format_row(i, text) on every core and appended in row order past
// the page cache: a thread appends its row (OpenMP `ordered`) while the others format theirs, so
// the copy into the write buffers overlaps the formatting instead of following it. A failed
// write (a full disk) stops the formatting at the next row and is rethrown here.
template <class FormatRow>
void write_rows(AtomicOutput& atomic, int rows, const FormatRow& format_row,
                const std::function<void(double)>& progress = nullptr) {
  DirectAppender out(atomic);
  const int progress_every = std::max(1, rows / 256);
  std::exception_ptr failure;  // set and read inside the ordered region only
  bool failed = false;
#pragma omp parallel
  {
    std::string text;
#pragma omp for ordered schedule(dynamic, 1)
    for (int i = 0; i < rows; ++i) {
      bool skip;
#pragma omp atomic read
      skip = failed;
      text.clear();
      if (!skip) format_row(i, text);
#pragma omp ordered
      {
        if (!failure) try {
            out.append(text.data(), text.size());
            if (progress && ((i + 1) % progress_every == 0 || i + 1 == rows)) progress(double(i + 1) / rows);
          } catch (...) {
            failure = std::current_exception();
#pragma omp atomic write
            failed = true;
          }
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  out.finish();
}

std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out(1, '"');
  for (char c : s) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
  return out;
}

// Row i of the sparse form ("i,j,F" lines of its entries >= threshold and > 0) appended to
// `text`; the entries below the threshold are added to dropped / dropped_count.
void format_sparse_row(int i, const double* row, int n, double threshold, std::string& text, double& dropped,
                       long long& dropped_count, long long& written) {
  char index[16];
  const size_t index_length = size_t(std::to_chars(index, index + sizeof index, i).ptr - index);
  // Straight into the row's memory, sized for every entry: "i," + j (at most 11 characters) +
  // "," + a shortest double + "\n".
  const size_t start = text.size();
  text.resize(start + size_t(n) * (index_length + 1 + 11 + 1 + kShortestDecimalMaxChars + 1));
  char* p = text.data() + start;
  for (int j = 0; j < n; ++j) {
    const double f = row[j];
    if (f == 0.0) continue;
    if (f < threshold) {
      dropped += f;
      ++dropped_count;
      continue;
    }
    std::memcpy(p, index, index_length);
    p += index_length;
    *p++ = ',';
    p = std::to_chars(p, p + 11, j).ptr;
    *p++ = ',';
    p = write_shortest(p, f);
    *p++ = '\n';
    ++written;
  }
  text.resize(size_t(p - text.data()));
}

bool little_endian() {
  const uint16_t one = 1;
  return *reinterpret_cast<const unsigned char*>(&one) == 1;
}

}  // namespace

std::string view_factor_format_name(ViewFactorFormat format) {
  switch (format) {
    case ViewFactorFormat::Csv: return "csv";
    case ViewFactorFormat::Sparse: return "sparse";
    case ViewFactorFormat::Binary: return "binary";
    case ViewFactorFormat::View3d: return "view3d";
  }
  return "?";
}

bool view_factor_format_from_name(const std::string& name, ViewFactorFormat& out) {
  for (ViewFactorFormat format :
       {ViewFactorFormat::Csv, ViewFactorFormat::Sparse, ViewFactorFormat::Binary, ViewFactorFormat::View3d})
    if (name == view_factor_format_name(format)) {
      out = format;
      return true;
    }
  return false;
}

ViewFactorForm::ViewFactorForm(ViewFactorFormat format, const std::vector<std::string>& names,
                               const std::vector<double>& areas, double threshold, const View3dOutput& view3d)
    : format_(format), names_(names), areas_(areas), threshold_(threshold), view3d_(view3d) {
  if (format_ == ViewFactorFormat::Binary && !little_endian())
    throw_io("binary view-factor output needs a little-endian host");
}

namespace {
// The value as View3D holds it (single precision; -0 printed as 0), then as its printf would.
void view3d_field(std::string& line, double v, std::chars_format format, int precision) {
  append_printf_like(line, static_cast<double>(static_cast<float>(v == 0.0 ? 0.0 : v)), format, precision);
}

template <class T>
void put(std::string& out, T v) {
  // Little-endian hosts only (checked by ViewFactorForm): the in-memory bytes are the file's.
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
}  // namespace

std::string ViewFactorForm::header() const {
  const int n = this->n();
  std::string out;
  switch (format_) {
    case ViewFactorFormat::Csv: {
      out = "name,area";
      for (const std::string& s : names_) out.append(1, ',').append(csv_cell(s));
      out += "\n";
      break;
    }
    case ViewFactorFormat::Sparse:
      for (size_t i = 0; i < names_.size(); ++i)
        out += "# surface," + std::to_string(i) + "," + csv_cell(names_[i]) + "," + shortest(areas_[i]) + "\n";
      out += "i,j,F\n";
      break;
    case ViewFactorFormat::Binary:
      out.append("PMVF\0\0\0\1", 8);
      put<uint64_t>(out, static_cast<uint64_t>(n));
      for (const std::string& s : names_) {
        put<uint32_t>(out, static_cast<uint32_t>(s.size()));
        out.append(s);
      }
      for (int i = 0; i < n; ++i) put<double>(out, areas_[size_t(i)]);
      break;
    case ViewFactorFormat::View3d: {
      // View3D's SaveVF, output format 0 (docs/viewfactors.md "The view3d form"): its values
      // are single precision (R4) printed with C's %g / %.6f / %.3f, blank-separated.
      std::string line = view3d_.program + " " + view3d_.version + " 0 " + std::to_string(view3d_.enclosure) + " " +
                         std::to_string(view3d_.emittances) + " " + std::to_string(n);
      if (line.size() < 30) line.resize(30, ' ');
      out = line + "\n";
      for (int i = 0; i < n; ++i) {
        if (i) out.push_back(' ');
        view3d_field(out, areas_[size_t(i)], std::chars_format::general, 6);  // %g
      }
      out += "\n";
      break;
    }
  }
  return out;
}

void ViewFactorForm::row(int i, const double* F_row, std::string& text, RowDrops& row) const {
  const int n = this->n();
  switch (format_) {
    case ViewFactorFormat::Csv: {
      text.append(csv_cell(names_[size_t(i)])).push_back(',');
      append_shortest(text, areas_[size_t(i)]);
      // Straight into the row's memory: a shortest double takes at most 24 characters.
      const size_t start = text.size();
      text.resize(start + size_t(n) * (kShortestDecimalMaxChars + 1) + 1);
      char* p = text.data() + start;
      for (int j = 0; j < n; ++j) {
        *p++ = ',';
        p = write_shortest(p, F_row[j]);
      }
      *p++ = '\n';
      text.resize(size_t(p - text.data()));
      break;
    }
    case ViewFactorFormat::Sparse:
      format_sparse_row(i, F_row, n, threshold_, text, row.dropped, row.dropped_count, row.written);
      break;
    case ViewFactorFormat::Binary:
      // Little-endian (checked at construction): the in-memory bytes are the file's.
      text.append(reinterpret_cast<const char*>(F_row), sizeof(double) * size_t(n));
      break;
    case ViewFactorFormat::View3d:
      text.reserve(text.size() + size_t(n) * 9);
      for (int j = 0; j < n; ++j) {
        if (j) text.push_back(' ');
        view3d_field(text, F_row[j], std::chars_format::fixed, 6);  // %.6f
      }
      text.push_back('\n');
      break;
  }
}

std::string ViewFactorForm::trailer() const {
  std::string line;
  if (format_ != ViewFactorFormat::View3d) return line;
  const int n = this->n();
  const bool have_emit = view3d_.emissivities.size() == static_cast<size_t>(n);
  for (int i = 0; i < n; ++i) {
    if (i) line.push_back(' ');
    view3d_field(line, have_emit ? view3d_.emissivities[size_t(i)] : 1.0, std::chars_format::fixed, 3);  // %.3f
  }
  return line + "\n";
}

void add_row_drops(SparseWriteStats& st, const RowDrops& row, int i) {
  st.written += row.written;
  st.dropped += row.dropped_count;
  st.total_dropped += row.dropped;
  if (row.dropped > st.max_dropped_row_sum) {
    st.max_dropped_row_sum = row.dropped;
    st.worst_row = i;
  }
}

SparseWriteStats write_view_factors(AtomicOutput& atomic, ViewFactorFormat format,
                                    const std::vector<std::string>& names, const std::vector<double>& areas,
                                    const ViewFactorRows& F, double threshold, const View3dOutput& view3d,
                                    const std::function<void(double)>& progress) {
  const ViewFactorForm form(format, names, areas, threshold, view3d);
  const int n = form.n();
  SparseWriteStats st;
  atomic.stream() << form.header();
  if (format == ViewFactorFormat::Binary) {
    DirectAppender matrix(atomic);  // the whole matrix at once (past the page cache, direct_append.h)
    matrix.append(reinterpret_cast<const char*>(F.data()), sizeof(double) * size_t(n) * size_t(n));
    matrix.finish();
    if (progress) progress(1.0);
  } else {
    std::vector<RowDrops> rows(format == ViewFactorFormat::Sparse ? size_t(n) : 0);
    write_rows(
        atomic, n,
        [&](int i, std::string& text) {
          RowDrops unused;
          form.row(i, F.row(i).data(), text, rows.empty() ? unused : rows[size_t(i)]);
        },
        progress);
    for (size_t i = 0; i < rows.size(); ++i) add_row_drops(st, rows[i], int(i));
  }
  atomic.stream() << form.trailer();
  atomic.check_stream();  // the caller's commit() flushes, closes and syncs
  return st;
}

struct ViewFactorRowStream::State {
  State(AtomicOutput& out, ViewFactorFormat format, const std::vector<std::string>& names,
        const std::vector<double>& areas, double threshold, const View3dOutput& view3d)
      : form(format, names, areas, threshold, view3d) {
    out.stream() << form.header();
    out.check_stream();
    appender.emplace(out);
  }
  ViewFactorForm form;
  std::optional<DirectAppender> appender;  // the rows, past the page cache
};

ViewFactorRowStream::ViewFactorRowStream(AtomicOutput& out, ViewFactorFormat format,
                                         const std::vector<std::string>& names, const std::vector<double>& areas,
                                         double threshold, const View3dOutput& view3d)
    : out_(out), n_(static_cast<int>(names.size())) {
  state_ = std::make_unique<State>(out, format, names, areas, threshold, view3d);
}

ViewFactorRowStream::~ViewFactorRowStream() = default;

void ViewFactorRowStream::add_row(int i, const double* F_row) {
  Row row;
  state_->form.row(i, F_row, row.text, row.drops);
  const std::lock_guard<std::mutex> lock(mutex_);
  write_in_order(std::move(row), i);
}

void ViewFactorRowStream::write_in_order(Row row, int i) {
  if (i != next_) {
    waiting_.emplace(i, std::move(row));
    return;
  }
  for (;;) {
    state_->appender->append(row.text.data(), row.text.size());
    add_row_drops(stats_, row.drops, next_);  // in row order, as write_view_factors sums them
    ++next_;
    const auto it = waiting_.find(next_);
    if (it == waiting_.end()) break;
    row = std::move(it->second);
    waiting_.erase(it);
  }
}

SparseWriteStats ViewFactorRowStream::finish() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (next_ != n_ || !waiting_.empty())
    throw std::logic_error("ViewFactorRowStream: " + std::to_string(n_ - next_) + " rows were not added");
  state_->appender->finish();
  out_.stream() << state_->form.trailer();
  out_.check_stream();
  return stats_;
}

void write_point_factors(AtomicOutput& atomic, const std::vector<std::string>& point_ids,
                         const std::vector<std::string>& surface_names, const ViewFactorRows& P) {
  {
    std::ofstream& out = atomic.stream();
    std::string line = "point";
    for (const std::string& s : surface_names) line.append(1, ',').append(csv_cell(s));
    out << line << "\n";
    write_rows(atomic, static_cast<int>(P.rows()), [&](int i, std::string& row) {
      row = csv_cell(point_ids[static_cast<size_t>(i)]);
      for (int j = 0; j < static_cast<int>(P.cols()); ++j) {
        row.push_back(',');
        append_shortest(row, P(i, j));
      }
      row.push_back('\n');
    });
    atomic.check_stream();
  }
}

}  // namespace photometria
