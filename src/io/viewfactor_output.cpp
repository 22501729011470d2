// View-factor matrix writers (viewfactor_output.h).
#include "io/viewfactor_output.h"

#include <omp.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/direct_append.h"
#include "util/error.h"

namespace photometria {

namespace {

// The shortest decimal that reads back as the same double (std::to_chars without a precision:
// round-trip exact, and at most 17 significant digits; Steele & White, "How to print
// floating-point numbers accurately", PLDI 1990, as implemented by the C++17 library).
void append_shortest(std::string& out, double v) {
  char buf[32];
  out.append(buf, size_t(std::to_chars(buf, buf + sizeof buf, v).ptr - buf));
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

// The sparse form's "# surface" lines and its "i,j,F" header.
void write_sparse_header(std::ofstream& out, const std::vector<std::string>& names, const std::vector<double>& areas) {
  for (size_t i = 0; i < names.size(); ++i)
    out << "# surface," << i << "," << csv_cell(names[i]) << "," << shortest(areas[i]) << "\n";
  out << "i,j,F\n";
}

// Row i of the sparse form ("i,j,F" lines of its entries >= threshold and > 0) appended to
// `text`; the entries below the threshold are added to dropped / dropped_count.
void format_sparse_row(int i, const double* row, int n, double threshold, std::string& text, double& dropped,
                       long long& dropped_count, long long& written) {
  char index[16];
  const size_t index_length = size_t(std::to_chars(index, index + sizeof index, i).ptr - index);
  for (int j = 0; j < n; ++j) {
    const double f = row[j];
    if (f == 0.0) continue;
    if (f < threshold) {
      dropped += f;
      ++dropped_count;
      continue;
    }
    text.append(index, index_length).push_back(',');
    char column[16];
    text.append(column, size_t(std::to_chars(column, column + sizeof column, j).ptr - column)).push_back(',');
    append_shortest(text, f);
    text.push_back('\n');
    ++written;
  }
}

template <class T>
void put(std::ofstream& out, T v) {
  // Little-endian hosts only (checked below): the in-memory bytes are the file's.
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
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

SparseWriteStats write_view_factors(AtomicOutput& atomic, ViewFactorFormat format,
                                    const std::vector<std::string>& names, const std::vector<double>& areas,
                                    const ViewFactorRows& F, double threshold, const View3dOutput& view3d,
                                    const std::function<void(double)>& progress) {
  SparseWriteStats st;
  const int n = static_cast<int>(F.rows());
  {
    std::ofstream& out = atomic.stream();
    switch (format) {
      case ViewFactorFormat::Csv: {
        std::string line = "name,area";
        for (const std::string& s : names) line.append(1, ',').append(csv_cell(s));
        out << line << "\n";
        write_rows(
            atomic, n,
            [&](int i, std::string& row) {
              row = csv_cell(names[size_t(i)]);
              row.push_back(',');
              append_shortest(row, areas[size_t(i)]);
              // Straight into the row's memory: a shortest double takes at most 24 characters.
              const size_t start = row.size();
              row.resize(start + size_t(n) * 25 + 1);
              char* p = row.data() + start;
              for (int j = 0; j < n; ++j) {
                *p++ = ',';
                p = std::to_chars(p, p + 24, F(i, j)).ptr;
              }
              *p++ = '\n';
              row.resize(size_t(p - row.data()));
            },
            progress);
        break;
      }
      case ViewFactorFormat::Sparse: {
        write_sparse_header(out, names, areas);
        // Per row, from the formatting threads; summed in row order afterwards.
        std::vector<double> dropped(size_t(n), 0.0);
        std::vector<long long> dropped_count(size_t(n), 0), written(size_t(n), 0);
        write_rows(
            atomic, n,
            [&](int i, std::string& row) {
              format_sparse_row(i, F.row(i).data(), n, threshold, row, dropped[size_t(i)], dropped_count[size_t(i)],
                                written[size_t(i)]);
            },
            progress);
        for (int i = 0; i < n; ++i) {
          st.written += written[size_t(i)];
          st.dropped += dropped_count[size_t(i)];
          st.total_dropped += dropped[size_t(i)];
          if (dropped[size_t(i)] > st.max_dropped_row_sum) {
            st.max_dropped_row_sum = dropped[size_t(i)];
            st.worst_row = i;
          }
        }
        break;
      }
      case ViewFactorFormat::Binary: {
        if (!little_endian()) throw_io("binary view-factor output needs a little-endian host");
        out.write("PMVF\0\0\0\1", 8);
        put<uint64_t>(out, static_cast<uint64_t>(n));
        for (const std::string& s : names) {
          put<uint32_t>(out, static_cast<uint32_t>(s.size()));
          out.write(s.data(), static_cast<std::streamsize>(s.size()));
        }
        for (int i = 0; i < n; ++i) put<double>(out, areas[i]);
        DirectAppender matrix(atomic);  // past the page cache (direct_append.h)
        matrix.append(reinterpret_cast<const char*>(F.data()), sizeof(double) * size_t(n) * size_t(n));
        matrix.finish();
        break;
      }
      case ViewFactorFormat::View3d: {
        // View3D's SaveVF, output format 0 (docs/viewfactors.md "The view3d form"): its values
        // are single precision (R4) printed with C's %g / %.6f / %.3f, blank-separated.
        std::string header = view3d.program + " " + view3d.version + " 0 " + std::to_string(view3d.enclosure) + " " +
                             std::to_string(view3d.emittances) + " " + std::to_string(n);
        if (header.size() < 30) header.resize(30, ' ');
        out << header << "\n";
        // The value as View3D holds it (single precision; -0 printed as 0), then as its printf would.
        const auto field = [](std::string& line, double v, std::chars_format format, int precision) {
          append_printf_like(line, static_cast<double>(static_cast<float>(v == 0.0 ? 0.0 : v)), format, precision);
        };
        std::string line;
        for (int i = 0; i < n; ++i) {
          if (i) line.push_back(' ');
          field(line, areas[size_t(i)], std::chars_format::general, 6);  // %g
        }
        out << line << "\n";
        write_rows(
            atomic, n,
            [&](int i, std::string& row) {
              row.reserve(size_t(n) * 9);
              for (int j = 0; j < n; ++j) {
                if (j) row.push_back(' ');
                field(row, F(i, j), std::chars_format::fixed, 6);  // %.6f
              }
              row.push_back('\n');
            },
            progress);
        line.clear();
        const bool have_emit = view3d.emissivities.size() == static_cast<size_t>(n);
        for (int i = 0; i < n; ++i) {
          if (i) line.push_back(' ');
          field(line, have_emit ? view3d.emissivities[size_t(i)] : 1.0, std::chars_format::fixed, 3);  // %.3f
        }
        out << line << "\n";
        break;
      }
    }
    atomic.check_stream();  // the caller's commit() flushes, closes and syncs
  }
  return st;
}

SparseRowStream::SparseRowStream(AtomicOutput& out, const std::vector<std::string>& names,
                                 const std::vector<double>& areas, double threshold)
    : out_(out), n_(static_cast<int>(names.size())), threshold_(threshold) {
  write_sparse_header(out_.stream(), names, areas);
  out_.check_stream();
}

void SparseRowStream::add_row(int i, const double* F_row) {
  Row row;
  format_sparse_row(i, F_row, n_, threshold_, row.text, row.dropped, row.dropped_count, row.written);
  const std::lock_guard<std::mutex> lock(mutex_);
  write_in_order(std::move(row), i);
}

void SparseRowStream::write_in_order(Row row, int i) {
  if (i != next_) {
    waiting_.emplace(i, std::move(row));
    return;
  }
  std::ofstream& out = out_.stream();
  for (;;) {
    out.write(row.text.data(), std::streamsize(row.text.size()));
    // In row order, as write_view_factors sums them.
    stats_.written += row.written;
    stats_.dropped += row.dropped_count;
    stats_.total_dropped += row.dropped;
    if (row.dropped > stats_.max_dropped_row_sum) {
      stats_.max_dropped_row_sum = row.dropped;
      stats_.worst_row = next_;
    }
    ++next_;
    const auto it = waiting_.find(next_);
    if (it == waiting_.end()) break;
    row = std::move(it->second);
    waiting_.erase(it);
  }
  out_.check_stream();
}

SparseWriteStats SparseRowStream::finish() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (next_ != n_ || !waiting_.empty())
    throw std::logic_error("SparseRowStream: " + std::to_string(n_ - next_) + " rows were not added");
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
