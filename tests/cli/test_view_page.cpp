// spacearm view's page (cli/view_page.hpp): the data cannot leave its <script> element, whatever
// its strings hold, and reads back unchanged.
#include <gtest/gtest.h>

#include <string>

#include "view_page.hpp"

namespace {

using nlohmann::json;
using spacearm::cli::json_for_script;
using spacearm::cli::view_page;

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(ViewPage, StringsStayDataInsideTheScript) {
  const std::string hostile =
      "</script><script>alert(1)</script><!-- & <b>\xE2\x80\xA8\xE2\x80\xA9 \"quoted\" \\";
  const json data = {{"title", hostile}, {"info", {{hostile, hostile}}}};
  const std::string text = json_for_script(data);
  for (const char* bad : {"<", ">", "&", "\xE2\x80\xA8", "\xE2\x80\xA9"})
    EXPECT_EQ(text.find(bad), std::string::npos) << bad;
  for (const char c : text) EXPECT_TRUE(static_cast<unsigned char>(c) < 0x80);
  EXPECT_EQ(json::parse(text), data);  // JSON.parse reads the same escapes
}

TEST(ViewPage, InvalidUtf8IsReplacedNotThrown) {
  const json data = {{"title", std::string("bad \xC3\x28 byte")}};
  const json back = json::parse(json_for_script(data));
  EXPECT_EQ(back["title"], "bad \xEF\xBF\xBD( byte");
}

TEST(ViewPage, OnePageTwoScriptsAndTheViewer) {
  const std::string page = view_page({{"title", "</script><script>alert(1)</script>"}});
  EXPECT_EQ(count(page, "</script"), 2u);  // the data's and the viewer's, nothing else
  EXPECT_EQ(count(page, "<script"), 2u);
  EXPECT_NE(page.find("Content-Security-Policy"), std::string::npos);
  if (spacearm::cli::viewer_built()) {
    EXPECT_GT(page.size(), 100000u);
  }
}

}  // namespace
