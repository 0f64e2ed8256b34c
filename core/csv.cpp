#include "core/csv.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/error.h"
#include "core/text.h"

namespace oslam {
namespace {

std::string Trim(const std::string& s) {
  const size_t begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const size_t end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream stream(line);
  while (std::getline(stream, field, ',')) fields.push_back(Trim(field));
  if (!line.empty() && line.back() == ',') fields.push_back("");
  return fields;
}

// A field as quoted in a message: short, so the message stays readable.
std::string Shown(const std::string& text) {
  return text.size() <= 40 ? text : text.substr(0, 37) + "...";
}

}  // namespace

CsvTable CsvTable::Read(const std::string& path) {
  return Parse(ReadTextFile(path), path);
}

CsvTable CsvTable::Parse(const std::string& text, const std::string& path_for_errors) {
  CsvTable table;
  table.path_ = path_for_errors;
  std::istringstream stream(text);
  std::string line;
  int line_number = 0;
  while (std::getline(stream, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    std::vector<std::string> fields = SplitFields(trimmed);
    if (table.header_.empty()) {
      table.header_ = std::move(fields);
      continue;
    }
    if (fields.size() != table.header_.size()) {
      throw Error::AtLine(path_for_errors, line_number,
                          "expected " + std::to_string(table.header_.size()) +
                              " fields as in the header, found " + std::to_string(fields.size()));
    }
    table.rows_.push_back(std::move(fields));
    table.lines_.push_back(line_number);
  }
  if (table.header_.empty()) throw Error::InFile(path_for_errors, "empty file (no header row)");
  return table;
}

int CsvTable::ColumnIndexOrMinusOne(const std::string& name) const {
  for (size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return static_cast<int>(i);
  return -1;
}

int CsvTable::ColumnIndex(const std::string& name) const {
  const int index = ColumnIndexOrMinusOne(name);
  if (index >= 0) return index;
  std::string have;
  for (const auto& column : header_) have += (have.empty() ? "" : ", ") + column;
  throw Error::InFile(path_, "missing column '" + name + "' (header has: " + have + ")");
}

double CsvTable::Double(size_t row, int column) const {
  const std::string& text = rows_[row][column];
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) {
    throw Error::AtLine(path_, lines_[row],
                        "column '" + header_[column] + "': '" + Shown(text) + "' is not a number");
  }
  if (!std::isfinite(value)) {
    throw Error::AtLine(path_, lines_[row],
                        "column '" + header_[column] + "': value is NaN or infinite");
  }
  return value;
}

long CsvTable::Integer(size_t row, int column) const {
  const std::string& text = rows_[row][column];
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size()) {
    throw Error::AtLine(
        path_, lines_[row],
        "column '" + header_[column] + "': '" + Shown(text) + "' is not an integer");
  }
  if (errno == ERANGE)
    throw Error::AtLine(path_, lines_[row],
                        "column '" + header_[column] + "': '" + Shown(text) + "' is too large");
  return value;
}

double CsvTable::Double(size_t row, int column, double low, double high,
                        const std::string& unit) const {
  const double value = Double(row, column);
  if (!bounds::Within(value, low, high))
    throw Error::AtLine(
        path_, lines_[row],
        "column '" + header_[column] + "': " + bounds::OutsideMessage(value, low, high, unit));
  return value;
}

long CsvTable::Integer(size_t row, int column, long low, long high) const {
  const long value = Integer(row, column);
  if (value < low || value > high)
    throw Error::AtLine(
        path_, lines_[row],
        "column '" + header_[column] + "': " +
            bounds::OutsideMessage(static_cast<double>(value), static_cast<double>(low),
                                   static_cast<double>(high)));
  return value;
}

std::string CsvNumber(double value) {
  return Number(value);
}

}  // namespace oslam
