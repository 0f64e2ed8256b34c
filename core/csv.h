// Minimal CSV with a header row, as used by the run folder. Every accessor
// reports errors as "FILE:LINE: problem".
#pragma once

#include <string>
#include <vector>

namespace oslam {

class CsvTable {
 public:
  // Parses `path`. Blank lines and lines starting with '#' are skipped. Throws
  // oslam::Error on a missing file, an empty file, or a row whose field count
  // differs from the header.
  static CsvTable Read(const std::string& path);
  static CsvTable Parse(const std::string& text, const std::string& path_for_errors);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }
  size_t num_rows() const { return rows_.size(); }
  int line_of_row(size_t row) const { return lines_[row]; }

  bool HasColumn(const std::string& name) const { return ColumnIndexOrMinusOne(name) >= 0; }
  // Throws "FILE: missing column NAME (have: a, b, c)".
  int ColumnIndex(const std::string& name) const;

  const std::string& Text(size_t row, int column) const { return rows_[row][column]; }
  // A finite double; throws "FILE:LINE: column NAME: 'abc' is not a number" /
  // "... is NaN or infinite".
  double Double(size_t row, int column) const;
  // As Double, and within [low, high] (core/bounds.h): "FILE:LINE: column
  // NAME: 1e+30 is outside [-100000, 100000] m (...)".
  double Double(size_t row, int column, double low, double high,
                const std::string& unit = "") const;
  long Integer(size_t row, int column) const;
  // As Integer, and within [low, high].
  long Integer(size_t row, int column, long low, long high) const;

 private:
  int ColumnIndexOrMinusOne(const std::string& name) const;

  std::string path_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> lines_;
};

// Formats numbers for CSV output with round-trip precision.
std::string CsvNumber(double value);

}  // namespace oslam
