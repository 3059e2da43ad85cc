// HTML building blocks of the report (html.hpp): one self-contained page, tables, figures and notes, escaped.
#include "report/html.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "report/svg.hpp"

namespace guideway::report {

namespace {

// Screen: a readable column. Print (A4): every analysis starts on a new page, figures and tables are not
// split, plots shrink to the text width (760 px viewBox -> 186 mm: 12 px text prints at about 8 pt); on
// screen a plot is never drawn larger than its own size (its text stays 12 px).
constexpr const char* kCss = R"css(
body { font-family: "DejaVu Sans", Arial, sans-serif; color: #111; margin: 24px auto; max-width: 840px;
       padding: 0 12px; line-height: 1.35; }
h1 { font-size: 22px; margin-bottom: 4px; }
h2 { font-size: 18px; border-bottom: 2px solid #0072b2; padding-bottom: 2px; margin-top: 32px; }
h3 { font-size: 15px; margin: 18px 0 6px; }
p.subtitle { color: #444; margin-top: 0; font-size: 13px; }
nav ol { font-size: 13px; }
figure { margin: 12px 0 18px; break-inside: avoid; page-break-inside: avoid; }
figcaption { font-size: 12px; color: #333; margin-top: 4px; }
svg.plot { max-width: 100%; height: auto; display: block; margin: 0 auto; }
svg.plot[data-plot="polar"] { margin: 0 auto; }
div.side-by-side { display: flex; flex-wrap: wrap; gap: 12px; align-items: flex-start; }
div.side-by-side > figure { flex: 1 1 380px; min-width: 0; }
table { border-collapse: collapse; font-size: 12px; margin: 8px 0 14px; break-inside: avoid;
        page-break-inside: avoid; }
caption { text-align: left; font-weight: bold; font-size: 13px; padding-bottom: 4px; }
th, td { border: 1px solid #bbb; padding: 2px 7px; text-align: right; vertical-align: top; }
th { background: #eef3f8; }
td:first-child, th:first-child { text-align: left; }
table.text td, table.text th, td.l, th.l { text-align: left; }
code, td:first-child { font-family: "DejaVu Sans Mono", monospace; font-size: 11.5px; }
.note { background: #fff8e1; border-left: 4px solid #e69f00; padding: 6px 10px; font-size: 13px; margin: 10px 0; }
@page { size: A4; margin: 12mm; }
@media print {
  body { margin: 0; max-width: none; padding: 0; }
  nav { display: none; }
  section.analysis { break-before: page; page-break-before: always; }
  h2 { margin-top: 0; }
  svg.plot[data-plot="polar"] { max-width: min(100%, 120mm); }
}
)css";

}  // namespace

std::string html_escape(std::string_view text) { return xml_escape(text); }

std::string html_table(const Table& table) {
  std::ostringstream o;
  o << (table.cls.empty() ? std::string("<table>") : "<table class=\"" + html_escape(table.cls) + "\">");
  if (!table.caption.empty()) o << "<caption>" << table.caption << "</caption>";
  const auto open_cell = [&](const char* tag, std::size_t column) {
    const bool text =
        std::find(table.text_columns.begin(), table.text_columns.end(), column) != table.text_columns.end();
    return std::string("<") + tag + (text ? " class=\"l\">" : ">");
  };
  if (!table.header.empty()) {
    o << "<thead><tr>";
    for (std::size_t c = 0; c < table.header.size(); ++c) o << open_cell("th", c) << table.header[c] << "</th>";
    o << "</tr></thead>";
  }
  o << "<tbody>";
  for (const auto& row : table.rows) {
    o << "<tr>";
    for (std::size_t c = 0; c < row.size(); ++c) o << open_cell("td", c) << row[c] << "</td>";
    o << "</tr>";
  }
  o << "</tbody></table>";
  return o.str();
}

std::string html_figure(const std::string& svg, const std::string& caption_html) {
  return "<figure>" + svg + (caption_html.empty() ? "" : "<figcaption>" + caption_html + "</figcaption>") + "</figure>";
}

std::string html_note(std::string_view text) { return "<p class=\"note\">" + html_escape(text) + "</p>"; }

std::string html_section(std::string_view kind, std::string_view id, std::string_view heading,
                         const std::string& body_html) {
  return "<section class=\"analysis\" data-kind=\"" + html_escape(kind) + "\" id=\"" + html_escape(id) + "\"><h2>" +
         html_escape(heading) + "</h2>" + body_html + "</section>";
}

std::string html_document(std::string_view title, std::string_view subtitle, const std::vector<TocEntry>& toc,
                          const std::string& body_html) {
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
    << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
    << "<meta name=\"generator\" content=\"guideway report\">"
    // Nothing may be fetched: the page is one file, viewable offline.
    << "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; "
       "img-src data:\">"
    << "<title>" << html_escape(title) << "</title><style>" << kCss << "</style></head><body>";
  o << "<header><h1>" << html_escape(title) << "</h1>";
  if (!subtitle.empty()) o << "<p class=\"subtitle\">" << html_escape(subtitle) << "</p>";
  o << "</header>";
  if (toc.size() > 1) {
    o << "<nav><ol>";
    for (const auto& e : toc)
      o << "<li><a href=\"#" << html_escape(e.id) << "\">" << html_escape(e.heading) << "</a></li>";
    o << "</ol></nav>";
  }
  o << "<main>" << body_html << "</main></body></html>\n";
  return o.str();
}

}  // namespace guideway::report
