#include "core/yaml.h"

#include <fstream>

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

TEST(YamlFile, ReadsWithOrWithoutDirective) {
  testing::TempDir dir;
  std::ofstream(dir.Path("a.yaml")) << "x: 1.5\nname: box\nlist: [1, 2, 3]\n";
  std::ofstream(dir.Path("b.yaml")) << "%YAML:1.0\n---\nx: 1.5\n";
  const YamlFile a(dir.Path("a.yaml"));
  EXPECT_DOUBLE_EQ(a.Double(a.root(), "x"), 1.5);
  EXPECT_EQ(a.String(a.root(), "name"), "box");
  EXPECT_EQ(a.Doubles(a.root(), "list", 3), (std::vector<double>{1, 2, 3}));
  EXPECT_DOUBLE_EQ(a.OptionalDouble(a.root(), "missing", 7.0), 7.0);
  const YamlFile b(dir.Path("b.yaml"));
  EXPECT_DOUBLE_EQ(b.Double(b.root(), "x"), 1.5);
}

TEST(YamlFile, SyntaxErrorNamesTheUsersLine) {
  testing::TempDir dir;
  std::ofstream(dir.Path("bad.yaml")) << "a: 1\nb: 2\n  c: 3\n";
  try {
    YamlFile file(dir.Path("bad.yaml"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              dir.Path("bad.yaml") + ": YAML syntax error at line 3: Incorrect indentation");
  }
}

TEST(YamlFile, WrongTypesAndUnknownKeysAreErrors) {
  testing::TempDir dir;
  std::ofstream(dir.Path("a.yaml")) << "x: abc\nn: 1.5\nlist: [1, 2]\ntypo: 3\n";
  const YamlFile file(dir.Path("a.yaml"));
  const std::string prefix = dir.Path("a.yaml") + ": ";
  auto error = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(error([&] { file.Double(file.root(), "x"); }), prefix + "x: must be a number");
  EXPECT_EQ(error([&] { file.Int(file.root(), "n"); }), prefix + "n: must be an integer");
  EXPECT_EQ(error([&] { file.Doubles(file.root(), "list", 3); }),
            prefix + "list: expected 3 numbers, found 2");
  EXPECT_EQ(error([&] { file.Double(file.root(), "absent", "outer."); }),
            prefix + "outer.absent: missing");
  EXPECT_EQ(error([&] { file.RequireOnlyKeys(file.root(), "", {"x", "n", "list"}); }),
            prefix + "typo: unknown key (allowed: x, n, list)");
}

}  // namespace
}  // namespace oslam
