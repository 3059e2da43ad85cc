#pragma once
// HTML building blocks of the report: one self-contained page (inline CSS, inline SVG, no scripts,
// nothing fetched), tables, figures and notes (numbers: core/number_format.hpp). Pure; thread safe.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::report {

// Text content for HTML (the same escaping as XML).
[[nodiscard]] std::string html_escape(std::string_view text);

// A table; cells are HTML (escape text first). The first column is left-aligned (names), and the
// text_columns; the rest right (numbers).
struct Table {
  Table(std::string caption_html, std::vector<std::string> header_html,
        std::vector<std::vector<std::string>> rows_html = {}, std::string css_class = {})
      : caption(std::move(caption_html)),
        header(std::move(header_html)),
        rows(std::move(rows_html)),
        cls(std::move(css_class)) {}
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string cls;                        // CSS class: "text" left-aligns every column
  std::vector<std::size_t> text_columns;  // more left-aligned columns (words, not numbers), by index
};
[[nodiscard]] std::string html_table(const Table& table);

// A figure with its caption (svg: one rendered plot).
[[nodiscard]] std::string html_figure(const std::string& svg, const std::string& caption_html);
// A highlighted remark (limitations, refusals) — text is escaped.
[[nodiscard]] std::string html_note(std::string_view text);

// One analysis: <section class="analysis" data-kind=KIND id=ID> with its heading.
[[nodiscard]] std::string html_section(std::string_view kind, std::string_view id, std::string_view heading,
                                       const std::string& body_html);

// The whole page: title, an optional line under it, a table of contents of the sections, and the sections.
struct TocEntry {
  std::string id;
  std::string heading;
};
[[nodiscard]] std::string html_document(std::string_view title, std::string_view subtitle,
                                        const std::vector<TocEntry>& toc, const std::string& body_html);

}  // namespace guideway::report
