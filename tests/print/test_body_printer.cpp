// generator/print/body_printer.hpp, tested directly: a node that several entries share is one
// named temporary, each entry one assignment in the spelling asked for (Eigen's M(i, j) or the C
// interface's arrays), sin and cos of one angle a batch, plain bodies inline with no temporary,
// and a body split into parts passes its values through the work array, every temporary defined
// before it is used.
#include "body_printer.hpp"

#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace spacearm {
namespace {

size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::string whole(const BodyPrinter& b) {
  std::string text;
  for (int k = 0; k < b.num_parts(); ++k) text += b.part(k);
  return text;
}

// M[0] = x0*x1*x2, M[1] = x0*x1*x3, M[2] = sin(x2)*cos(x2) + x0*x1.
struct Body {
  Program p;
  std::vector<Assignment> entries;
  Body() {
    const SRef x0 = p.input("q", 0), x1 = p.input("q", 1), x2 = p.input("q", 2),
               x3 = p.input("q", 3);
    const SRef shared = p.mul({x0, x1});
    entries = {{"M(0, 0)", p.mul({shared, x2}), ""},
               {"M(0, 1)", p.mul({shared, x3}), ""},
               {"M(1, 0)", p.add({p.mul({p.sin(x2), p.cos(x2)}), shared}), ""},
               {"M(1, 1)", SRef{}, "M(0, 1)"}};
  }
};

TEST(BodyPrinter, ASharedNodeIsOneTemporaryAndEachEntryOneAssignment) {
  const Body b;
  const BodyPrinter printer(b.p, b.entries, false, Spelling::eigen);
  const std::string text = whole(printer);
  EXPECT_EQ(printer.num_parts(), 1);
  EXPECT_EQ(occurrences(text, "q(0) * q(1)"), 1u) << text;  // computed once
  for (const char* target : {"M(0, 0) = ", "M(0, 1) = ", "M(1, 0) = "})
    EXPECT_EQ(occurrences(text, target), 1u) << target << "\n" << text;
  EXPECT_NE(text.find("M(1, 1) = M(0, 1);"), std::string::npos) << text;  // a copy
  // sin and cos of one angle: one batch, each used once.
  EXPECT_TRUE(printer.has_trig_batches()) << text;
}

TEST(BodyPrinter, CArraysArePlainColumnMajorEntries) {
  Body b;
  b.entries = {{"M[0]", b.entries[0].root, ""}, {"M[2]", b.entries[1].root, ""}};
  const std::string text = whole(BodyPrinter(b.p, b.entries, false, Spelling::c_arrays));
  EXPECT_NE(text.find("q[0]"), std::string::npos) << text;
  EXPECT_EQ(text.find("q(0)"), std::string::npos) << text;
  EXPECT_NE(text.find("M[2] = "), std::string::npos) << text;
}

TEST(BodyPrinter, APlainBodyIsInlineWithNoTemporary) {
  const Body b;
  const BodyPrinter printer(b.p, b.entries, true, Spelling::eigen);
  const std::string text = whole(printer);
  EXPECT_EQ(text.find("const T t"), std::string::npos) << text;
  EXPECT_GE(occurrences(text, "q(0)"), 3u) << text;  // the shared product repeated
  EXPECT_EQ(printer.work_size(), 0);
}

TEST(BodyPrinter, PartsPassValuesThroughTheWorkArrayAndDefineBeforeUse) {
  Program p;
  std::vector<SRef> chain = {p.input("q", 0)};
  for (int k = 1; k < 12; ++k)
    chain.push_back(p.mul({chain.back(), p.add({chain.back(), p.input("q", k)})}));
  std::vector<Assignment> entries;
  for (int k = 0; k < 12; ++k)
    entries.push_back({"M(" + std::to_string(k) + ", 0)", chain[size_t(k)], ""});
  const BodyPrinter printer(p, entries, false, Spelling::eigen, 3);
  ASSERT_GT(printer.num_parts(), 1);
  EXPECT_GT(printer.work_size(), 0);
  EXPECT_NE(whole(printer).find("w["), std::string::npos);
  // Within each part, a temporary is defined before any statement reads it.
  const std::regex defined(R"(const T (t\d+) = )"), used(R"(\b(t\d+)\b)");
  for (int k = 0; k < printer.num_parts(); ++k) {
    std::set<std::string> seen;
    std::string line;
    std::istringstream in(printer.part(k));
    while (std::getline(in, line)) {
      std::smatch m;
      std::string rest = line;
      std::string name;
      if (std::regex_search(line, m, defined)) name = m[1], rest = m.suffix();
      for (std::sregex_iterator it(rest.begin(), rest.end(), used), end; it != end; ++it)
        EXPECT_TRUE(seen.count((*it)[1])) << (*it)[1] << " used before defined in part " << k;
      if (!name.empty()) seen.insert(name);
    }
  }
}

// A value read only in the next part frees its slot there: a long chain passes each link's value
// on through the same few slots instead of one slot per value, and every slot read in a part was
// written in an earlier one.
TEST(BodyPrinter, WorkSlotsAreReusedOnceTheirValueIsRead) {
  Program p;
  SRef x = p.input("q", 0);
  for (int k = 1; k < 40; ++k) x = p.mul({x, p.add({x, p.input("q", k % 7)})});
  const BodyPrinter printer(p, {{"M(0, 0)", x, ""}}, false, Spelling::eigen, 2);
  ASSERT_GE(printer.num_parts(), 8);
  EXPECT_LE(printer.work_size(), 2);
  const std::regex write(R"(\bw\[(\d+)\] = )"), read(R"(\bw\[(\d+)\])");
  std::set<std::string> written;
  size_t writes = 0;
  for (int k = 0; k < printer.num_parts(); ++k) {
    std::set<std::string> now;
    std::string line;
    std::istringstream in(printer.part(k));
    while (std::getline(in, line)) {
      std::smatch m;
      std::string rest = line;
      if (std::regex_search(line, m, write) && m.position(0) <= 2) {
        now.insert(m[1]);
        rest = m.suffix();
        ++writes;
      }
      for (std::sregex_iterator it(rest.begin(), rest.end(), read), end; it != end; ++it)
        EXPECT_TRUE(written.count((*it)[1]))
            << "w[" << (*it)[1] << "] read in part " << k << " before any part wrote it";
    }
    written.insert(now.begin(), now.end());
  }
  EXPECT_GE(writes, static_cast<size_t>(printer.num_parts() - 1));  // a value into every next part
}

}  // namespace
}  // namespace spacearm
