#include "view_page.hpp"

namespace spacearm::cli {

namespace {

#ifdef SPACEARM_VIEWER_BUNDLE
// The bundle as raw-string pieces (web/build.mjs writes viewer_bundle.inc).
const char kViewerScript[] =
#include "viewer_bundle.inc"
    ;
#else
const char kViewerScript[] = "";
#endif

}  // namespace

bool viewer_built() { return sizeof kViewerScript > 1; }

std::string json_for_script(const nlohmann::json& data) {
  const std::string ascii = data.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(ascii.size() + ascii.size() / 16);
  for (const char c : ascii) {
    if (c == '<')
      out += "\\u003c";
    else if (c == '>')
      out += "\\u003e";
    else if (c == '&')
      out += "\\u0026";
    else
      out += c;
  }
  return out;
}

std::string view_page(const nlohmann::json& data) {
  std::string page =
      "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
      "script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data: blob:\">\n"
      "<title>spacearm view</title>\n</head>\n<body>\n<div id=\"app\"></div>\n"
      "<script type=\"application/json\" id=\"spacearm-data\">";
  page += json_for_script(data);
  page += "</script>\n<script>";
  page += kViewerScript;
  page += "</script>\n</body>\n</html>\n";
  return page;
}

}  // namespace spacearm::cli
