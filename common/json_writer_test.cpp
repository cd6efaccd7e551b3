#include "common/json_writer.h"

#include <gtest/gtest.h>

namespace objscan {
namespace {

TEST(JsonQuoted, EscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(JsonQuoted("plain"), "\"plain\"");
  EXPECT_EQ(JsonQuoted("a \"b\" c\\d"), "\"a \\\"b\\\" c\\\\d\"");
  EXPECT_EQ(JsonQuoted("line\nnext\ttab\r"), "\"line\\nnext\\ttab\\r\"");
  EXPECT_EQ(JsonQuoted(std::string("nul\0bell\a", 9)), "\"nul\\u0000bell\\u0007\"");
  EXPECT_EQ(JsonQuoted("\xc3\xa9t\xc3\xa9"), "\"\xc3\xa9t\xc3\xa9\"");  // UTF-8 passes unchanged
  EXPECT_EQ(JsonQuoted(""), "\"\"");
}

TEST(JsonWriter, WritesNestedValuesWithEscapedKeysAndNullForNonFinite) {
  JsonWriter j;
  j.BeginObject().Key("na\"me").String("x\ny").Key("n").Number(1.5).Key("bad").Number(NAN).Key("list");
  j.BeginArray().Int(1).Bool(true).EndArray().EndObject();
  EXPECT_EQ(j.str(),
            "{\n  \"na\\\"me\": \"x\\ny\",\n  \"n\": 1.5,\n  \"bad\": null,\n  \"list\": [\n    1,\n    true\n  ]\n}");
}

}  // namespace
}  // namespace objscan
