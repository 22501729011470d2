// View-factor matrix writers (viewfactor_output.h).
#include "io/viewfactor_output.h"

#include <cstdint>
#include <cstdio>
#include <fstream>

#include "io/atomic_file.h"
#include "util/error.h"

namespace photometria {

namespace {

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
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
                                    const ViewFactorRows& F, double threshold, const View3dOutput& view3d) {
  SparseWriteStats st;
  const int n = static_cast<int>(F.rows());
  {
    std::ofstream& out = atomic.stream();
    switch (format) {
      case ViewFactorFormat::Csv: {
        std::string line = "name,area";
        for (const std::string& s : names) line.append(1, ',').append(csv_cell(s));
        out << line << "\n";
        for (int i = 0; i < n; ++i) {
          line = csv_cell(names[i]);
          line.append(1, ',').append(g17(areas[i]));
          for (int j = 0; j < n; ++j) line.append(1, ',').append(g17(F(i, j)));
          out << line << "\n";
          if (i % 256 == 255) atomic.check_stream();  // a full disk stops the run here, not at the end
        }
        break;
      }
      case ViewFactorFormat::Sparse: {
        for (int i = 0; i < n; ++i)
          out << "# surface," << i << "," << csv_cell(names[i]) << "," << g17(areas[i]) << "\n";
        out << "i,j,F\n";
        for (int i = 0; i < n; ++i) {
          double dropped = 0.0;
          for (int j = 0; j < n; ++j) {
            const double f = F(i, j);
            if (f == 0.0) continue;
            if (f < threshold) {
              dropped += f;
              ++st.dropped;
              continue;
            }
            out << i << "," << j << "," << g17(f) << "\n";
            ++st.written;
          }
          st.total_dropped += dropped;
          if (dropped > st.max_dropped_row_sum) {
            st.max_dropped_row_sum = dropped;
            st.worst_row = i;
          }
          if (i % 256 == 255) atomic.check_stream();
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
        out.write(reinterpret_cast<const char*>(F.data()), static_cast<std::streamsize>(sizeof(double) * n * n));
        break;
      }
      case ViewFactorFormat::View3d: {
        // View3D's SaveVF, output format 0 (docs/viewfactors.md "The view3d form"): its values
        // are single precision (R4) printed with C's %g / %.6f / %.3f, blank-separated.
        std::string header = view3d.program + " " + view3d.version + " 0 " + std::to_string(view3d.enclosure) + " 0 " +
                             std::to_string(n);
        if (header.size() < 30) header.resize(30, ' ');
        out << header << "\n";
        const auto field = [](const char* fmt, double v) {
          char buf[64];
          std::snprintf(buf, sizeof buf, fmt, static_cast<double>(static_cast<float>(v == 0.0 ? 0.0 : v)));
          return std::string(buf);
        };
        std::string line;
        for (int i = 0; i < n; ++i) line.append(i ? " " : "").append(field("%g", areas[i]));
        out << line << "\n";
        for (int i = 0; i < n; ++i) {
          line.clear();
          for (int j = 0; j < n; ++j) line.append(j ? " " : "").append(field("%.6f", F(i, j)));
          out << line << "\n";
          if (i % 256 == 255) atomic.check_stream();
        }
        line.clear();
        const bool have_emit = view3d.emissivities.size() == static_cast<size_t>(n);
        for (int i = 0; i < n; ++i)
          line.append(i ? " " : "")
              .append(field("%.3f", have_emit ? view3d.emissivities[static_cast<size_t>(i)] : 1.0));
        out << line << "\n";
        break;
      }
    }
    atomic.check_stream();  // the caller's commit() flushes, closes and syncs
  }
  return st;
}

void write_point_factors(AtomicOutput& atomic, const std::vector<std::string>& point_ids,
                         const std::vector<std::string>& surface_names, const ViewFactorRows& P) {
  {
    std::ofstream& out = atomic.stream();
    std::string line = "point";
    for (const std::string& s : surface_names) line.append(1, ',').append(csv_cell(s));
    out << line << "\n";
    for (int i = 0; i < static_cast<int>(P.rows()); ++i) {
      line = csv_cell(point_ids[static_cast<size_t>(i)]);
      for (int j = 0; j < static_cast<int>(P.cols()); ++j) line.append(1, ',').append(g17(P(i, j)));
      out << line << "\n";
      if (i % 256 == 255) atomic.check_stream();
    }
    atomic.check_stream();
  }
}

}  // namespace photometria
