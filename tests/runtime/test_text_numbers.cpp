// runtime/text_numbers.hpp: numbers from text are one finite decimal number in the range of
// double, or an error naming the field and quoting the text.
#include "text_numbers.hpp"

#include <gtest/gtest.h>

#include "support.hpp"

namespace spacearm {
namespace {

TEST(TextNumbers, DecimalNumbersAreRead) {
  EXPECT_EQ(parse_number("1.5", "x"), 1.5);
  EXPECT_EQ(parse_number("-2e-3", "x"), -2e-3);
  EXPECT_EQ(parse_number(".5", "x"), 0.5);
  EXPECT_EQ(parse_number("+3", "x"), 3);
  EXPECT_EQ(parse_number("010", "x"), 10);  // decimal, never octal
  EXPECT_EQ(parse_number_list("1,2,3", "--q", 3), (std::vector<double>{1, 2, 3}));
}

TEST(TextNumbers, EverythingElseIsAnErrorNamingTheField) {
  struct Case {
    std::string text, message;
  };
  for (const Case& c :
       std::vector<Case>{{"", "x: empty"},
                         {"abc", "x: 'abc' is not a number"},
                         {" 1", "x: ' 1' is not a number"},
                         {"1 ", "x: '1 ' is not a number"},
                         {"0x10", "x: '0x10' is not a number"},
                         {"1e999", "x: '1e999' is not finite"},
                         {"-inf", "x: '-inf' is not finite"},
                         {"nan", "x: 'nan' is not finite"},
                         {"1e-400", "x: '1e-400' is out of the range of double precision"},
                         {"3,5", "(a decimal comma? write a point)"},
                         {std::string("7\0"
                                      "5",
                                      3),
                          "holds a NUL byte"},
                         {std::string(200, '1'), "is too long for a number"}})
    EXPECT_THROW_MESSAGE(parse_number(c.text, "x"), std::invalid_argument, c.message);
  EXPECT_THROW_MESSAGE(parse_number_list("1,2,", "--q"), std::invalid_argument,
                       "--q[2]: empty item in '1,2,'");
  EXPECT_THROW_MESSAGE(parse_number_list(",1", "--q"), std::invalid_argument, "--q[0]: empty item");
  EXPECT_THROW_MESSAGE(parse_number_list("1,2", "--q", 3), std::invalid_argument,
                       "--q: expected 3 comma-separated values, got 2");
}

}  // namespace
}  // namespace spacearm
