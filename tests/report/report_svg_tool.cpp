// report_svg_tool line|polar: renders one plot of the data read from standard input ("x y" per line; for
// polar "angle_deg deviation_um") to standard output, for report_svg_xml_test.py.
// report_svg_tool report FILE...: the report of the files (an explanation's per-step panels) to standard output.
#include <cmath>
#include <iostream>
#include <numbers>
#include <string>

#include "report/report.hpp"
#include "report/svg.hpp"

int main(int argc, char** argv) {
  using namespace guideway::report;
  const std::string kind = argc > 1 ? argv[1] : "";
  if (kind == "report") {
    try {
      std::cout << render_report(std::vector<std::string>(argv + 2, argv + argc));
    } catch (const ReportError& e) {
      std::cerr << e.what() << "\n";
      return 1;
    }
    return 0;
  }
  std::vector<double> a, b;
  double x = 0, y = 0;
  while (std::cin >> x >> y) {
    a.push_back(x);
    b.push_back(y);
  }
  if (kind == "line") {
    LinePlot p;
    p.title = "test <&> plot";
    p.x_label = "x / mm";
    p.y_label = "y / \u00b5m";
    p.series = {Series{"data \"1\"", a, b, "", Style::line, 1.4}};
    std::cout << render(p);
  } else if (kind == "polar") {
    PolarPlot p;
    p.title = "polar";
    PolarSeries s;
    s.label = "run";
    for (std::size_t i = 0; i < a.size(); ++i) {
      s.angle_rad.push_back(a[i] * std::numbers::pi / 180);
      s.deviation_um.push_back(b[i]);
    }
    p.series = {s};
    std::cout << render(p);
  } else {
    std::cerr << "usage: report_svg_tool line|polar < data, or report FILE...\n";
    return 2;
  }
  return 0;
}
