// Arguments: options, flags and positionals; a command's modes (a selector
// option chooses the mode, options of another mode are usage errors naming
// it, --help groups the options by mode); and `oslam map`'s three modes as
// a user spells them.
#include "apps/arguments.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

// A command shaped like `oslam map`: -o common; RUN_DIR and --samples
// without a selector; --known (a flag) with RUN_DIR and --seed; --data FILE
// with --seed and --format.
Arguments MapLike() {
  Arguments a("map [...]", "three modes");
  a.AddOption("output", "-o", "FILE", "where to write");
  a.BeginMode("", "default mode", "", "");
  a.AddPositional("RUN_DIR", "the run");
  a.AddOption("samples", "", "N", "samples", "100");
  a.BeginMode("known", "known mode", "map RUN_DIR --known", "the known mode alone");
  a.AddPositional("RUN_DIR", "the run");
  a.AddFlag("known", "selects the known mode");
  a.AddOption("seed", "", "N", "noise seed", "1");
  a.BeginMode("data", "data mode", "map --data FILE", "the data mode alone");
  a.AddOption("data", "", "FILE", "selects the data mode");
  a.AddOption("seed", "", "N", "random seed", "7");
  a.AddOption("format", "", "NAME", "file format", "text");
  return a;
}

std::string UsageMessage(Arguments arguments, const std::vector<std::string>& args) {
  try {
    arguments.Parse(args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(Arguments, TheSelectorChoosesTheMode) {
  Arguments plain = MapLike();
  ASSERT_TRUE(plain.Parse({"run", "-o", "x.json", "--samples", "5"}));
  EXPECT_EQ(plain.mode(), "");
  EXPECT_EQ(plain.Get("RUN_DIR"), "run");
  EXPECT_EQ(plain.GetInt("samples"), 5);

  Arguments known = MapLike();
  ASSERT_TRUE(known.Parse({"run", "--seed", "3", "--known", "-o", "x.json"}));
  EXPECT_EQ(known.mode(), "known");
  EXPECT_EQ(known.Get("RUN_DIR"), "run");
  EXPECT_EQ(known.GetInt("seed"), 3);

  // The selector anywhere, also as --data=FILE; a mode's own default.
  Arguments data = MapLike();
  ASSERT_TRUE(data.Parse({"-o", "x.json", "--data=f.txt"}));
  EXPECT_EQ(data.mode(), "data");
  EXPECT_EQ(data.Get("data"), "f.txt");
  EXPECT_EQ(data.GetInt("seed"), 7);
  EXPECT_EQ(data.Get("format"), "text");

  // A value that looks like a selector is a value.
  Arguments value = MapLike();
  ASSERT_TRUE(value.Parse({"run", "-o", "--known"}));
  EXPECT_EQ(value.mode(), "");
  EXPECT_EQ(value.Get("output"), "--known");
}

TEST(Arguments, OptionsOfAnotherModeAreUsageErrorsNamingIt) {
  EXPECT_EQ(UsageMessage(MapLike(), {"run", "--seed", "2", "-o", "x"}),
            "option '--seed' needs --known or --data");
  EXPECT_EQ(UsageMessage(MapLike(), {"run", "--format", "csv", "-o", "x"}),
            "option '--format' needs --data");
  EXPECT_EQ(UsageMessage(MapLike(), {"--data", "f", "--samples", "3"}),
            "option '--samples' does not apply with --data");
  EXPECT_EQ(UsageMessage(MapLike(), {"run", "--known", "--data", "f"}),
            "--known and --data exclude each other");
  EXPECT_EQ(UsageMessage(MapLike(), {"--data", "f", "run"}), "unexpected argument 'run'");
  EXPECT_EQ(UsageMessage(MapLike(), {"--known"}), "missing argument RUN_DIR");
  EXPECT_EQ(UsageMessage(MapLike(), {"run", "--bogus"}), "unknown option '--bogus'");
}

TEST(Arguments, HelpGroupsTheOptionsByMode) {
  const std::string help = MapLike().Help();
  const size_t common = help.find("options of every mode:\n  -o, --output FILE");
  const size_t default_mode = help.find("\ndefault mode:\n  RUN_DIR\n");
  const size_t known = help.find("\nknown mode:\n  RUN_DIR\n");
  const size_t data = help.find("\ndata mode:\n  --data FILE");
  ASSERT_NE(common, std::string::npos) << help;
  ASSERT_NE(default_mode, std::string::npos) << help;
  ASSERT_NE(known, std::string::npos) << help;
  ASSERT_NE(data, std::string::npos) << help;
  EXPECT_LT(common, default_mode);
  EXPECT_LT(default_mode, known);
  EXPECT_LT(known, data);
  EXPECT_NE(help.find("--samples N\n      samples (default: 100)"), std::string::npos) << help;

  // Without modes: the plain layout.
  Arguments plain("cmd [options]", "one mode");
  plain.AddPositional("IN", "input");
  plain.AddOption("level", "", "N", "how much", "2");
  plain.AddFlag("quiet", "quiet");
  EXPECT_EQ(plain.Help(),
            "usage: cmd [options]\n\none mode\n\narguments:\n  IN\n      input\n\noptions:\n"
            "  --level N\n      how much (default: 2)\n  --quiet\n      quiet\n"
            "  -h, --help\n      show this help\n");
}

testing::CommandResult Oslam(const std::string& arguments) {
  return testing::RunShellCommand(std::string(OSLAM_BINARY) + " " + arguments);
}

// `oslam map`: every spelling of the three modes that worked keeps working;
// an option of another mode is a one-line usage error naming the mode.
TEST(MapModes, EachModeTakesItsOwnOptions) {
  const std::string landmarks =
      std::string(OSLAM_SOURCE_DIR) + "/tests/data/landmarks/gtsam_small.txt";
  testing::TempDir dir;
  const testing::CommandResult tree =
      Oslam("map --landmarks=" + landmarks + " -o " + dir.Path("t.json") + " --quiet");
  EXPECT_EQ(tree.exit_code, 0) << tree.err;

  struct Refused {
    std::string arguments, message;
  };
  for (const Refused& r : std::vector<Refused>{
           {"map run --keyframe-start 5 -o x",
            "option '--keyframe-start' needs --known-association"},
           {"map run --known-association --samples 5 -o x",
            "option '--samples' does not apply with --known-association"},
           {"map --landmarks " + landmarks + " --detections d.csv -o x",
            "option '--detections' does not apply with --landmarks"},
           {"map run --unknown-association -o x",
            "option '--unknown-association' needs --landmarks"},
           {"map run --known-association --landmarks f -o x",
            "--known-association and --landmarks exclude each other"},
       }) {
    const testing::CommandResult result = Oslam(r.arguments);
    EXPECT_EQ(result.exit_code, 2) << r.arguments;
    EXPECT_EQ(result.err, "oslam map: usage error: " + r.message + " (see 'oslam map --help')\n");
  }

  const testing::CommandResult help = Oslam("map --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* group : {"options of every mode:", "O-SLAM (no mode option; as 'oslam slam'):",
                            "(--known-association):", "(--landmarks FILE):", "--keyframe-start",
                            "--unknown-association", "--sampling-moves"})
    EXPECT_NE(help.out.find(group), std::string::npos) << group;
  const testing::CommandResult known_help = Oslam("map --known-association --help");
  EXPECT_EQ(known_help.out.rfind("usage: oslam map RUN_DIR --known-association", 0), 0u)
      << known_help.out;
  EXPECT_EQ(known_help.out.find("--sampling-moves"), std::string::npos);
}

}  // namespace
}  // namespace oslam
