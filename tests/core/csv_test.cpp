#include "core/csv.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace oslam {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Csv, ParsesHeaderRowsCommentsAndBlankLines) {
  const CsvTable table = CsvTable::Parse("# comment\na,b\n1, 2.5\n\n-3,4e-2\n", "t.csv");
  ASSERT_EQ(table.num_rows(), 2u);
  EXPECT_EQ(table.line_of_row(1), 5);
  EXPECT_DOUBLE_EQ(table.Double(0, table.ColumnIndex("b")), 2.5);
  EXPECT_EQ(table.Integer(1, 0), -3);
}

TEST(Csv, ErrorsNameFileLineAndColumn) {
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b\n1,2\n3\n", "t.csv"); }),
            "t.csv:3: expected 2 fields as in the header, found 1");
  const CsvTable table = CsvTable::Parse("a,b\n1,nan\nx,2\n", "t.csv");
  EXPECT_EQ(ErrorOf([&] { table.Double(0, 1); }), "t.csv:2: column 'b': value is NaN or infinite");
  EXPECT_EQ(ErrorOf([&] { table.Double(1, 0); }), "t.csv:3: column 'a': 'x' is not a number");
  EXPECT_EQ(ErrorOf([&] { table.ColumnIndex("c"); }), "t.csv: missing column 'c' (header has: a, b)");
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("\n# only a comment\n", "t.csv"); }),
            "t.csv: empty file (no header row)");
  EXPECT_EQ(ErrorOf([] { CsvTable::Read("/nonexistent.csv"); }).rfind("/nonexistent.csv: ", 0), 0u);
}

TEST(Csv, NumbersRoundTripExactly) {
  for (double value : {0.1, -1e-300, 3.141592653589793, 123456789.123456789}) {
    const CsvTable table = CsvTable::Parse("v\n" + CsvNumber(value) + "\n", "t.csv");
    EXPECT_EQ(table.Double(0, 0), value);
  }
  EXPECT_EQ(CsvNumber(0.1), "0.1");
}

}  // namespace
}  // namespace oslam
