#include "skidimm/printable.h"

#include <gtest/gtest.h>

#include "skidimm/errors.h"

namespace skidimm {
namespace {

TEST(Printable, EscapesControlBytesAndInvalidUtf8AndKeepsValidUtf8) {
  EXPECT_EQ(printable("plain text, 1.5 m/s"), "plain text, 1.5 m/s");
  EXPECT_EQ(printable("tab\tand\nnewline"), "tab\tand\nnewline");
  EXPECT_EQ(printable("\x1b[2Jclear"), "\\x1B[2Jclear");
  EXPECT_EQ(printable(std::string("nul\0byte", 8)), "nul\\x00byte");
  EXPECT_EQ(printable("\x7f"), "\\x7F");
  EXPECT_EQ(printable("\xc3\xa9t\xc3\xa9 \xe2\x88\x9a \xf0\x9f\x9a\x9c"), "\xc3\xa9t\xc3\xa9 \xe2\x88\x9a \xf0\x9f\x9a\x9c");
  EXPECT_EQ(printable("\xff\xfe"), "\\xFF\\xFE");
  EXPECT_EQ(printable("\xc3"), "\\xC3") << "a truncated sequence";
  EXPECT_EQ(printable("\xc0\xaf"), "\\xC0\\xAF") << "an overlong slash";
  EXPECT_EQ(printable("\xed\xa0\x80"), "\\xED\\xA0\\x80") << "a surrogate";
  EXPECT_EQ(printable("\xc2\x9b"), "\\xC2\\x9B") << "a C1 control (CSI)";
}

TEST(Printable, EveryErrorMessageIsMadePrintableWhenBuilt) {
  static const char kMessage[] = "column 'v': expected a number, got '\x1b]0;x\x07\0tail'";
  const LogError e("log.csv", 3, std::string(kMessage, sizeof(kMessage) - 1));
  const std::string what = e.what();
  EXPECT_EQ(what, "log.csv:3: column 'v': expected a number, got '\\x1B]0;x\\x07\\x00tail'");
}

}  // namespace
}  // namespace skidimm
