"""What the Chromium tests of Guideway's HTML pages (guideway report, guideway fleet report) read in a
loaded page, standard library only: the checks that the page stands alone, and the structure of every
section and plot (report/svg.hpp's fixed SVG structure) as one JavaScript query.
"""
import os
import re

import cdp

# Per <section class="analysis">: its kind, id, table count and each plot's axes, labels, legend and data paths.
PLOTS_JS = r"""
[...document.querySelectorAll('section.analysis')].map(sec => ({
  kind: sec.dataset.kind,
  id: sec.id,
  tables: sec.querySelectorAll('table').length,
  plots: [...sec.querySelectorAll('svg.plot')].map(svg => {
    const box = svg.getBoundingClientRect();
    return {
      kind: svg.dataset.plot,
      width: box.width, height: box.height,
      title: (svg.querySelector('text.title') || {}).textContent || '',
      axes: [...svg.querySelectorAll('g.axis')].map(g => ({cls: g.getAttribute('class'),
                                                          ticks: g.querySelectorAll('.tick, .ring, .spoke').length,
                                                          labels: [...g.querySelectorAll('text.tick-label')].map(t => t.textContent)})),
      axis_labels: [...svg.querySelectorAll('text.axis-label')].map(t => t.textContent),
      legend: [...svg.querySelectorAll('g.legend text')].map(t => t.textContent),
      data: [...svg.querySelectorAll('path.data')].map(p => {
        const b = p.getBBox();
        return {series: p.dataset.series, points: Number(p.dataset.points), d: (p.getAttribute('d') || '').length,
                segs: ((p.getAttribute('d') || '').match(/[MLHVZ]/g) || []).length, w: b.width, h: b.height};
      }),
      panels: svg.querySelectorAll('g.panel').length,
    };
  }),
}))
"""


# Per plot: the box of every text it draws (titles, tick labels, axis labels, value labels, legend), in page
# pixels as laid out, to check that no two run into each other and none is cut by the plot's edge.
TEXT_BOXES_JS = r"""
[...document.querySelectorAll('svg.plot')].map(svg => {
  const box = r => ({l: r.left, r: r.right, t: r.top, b: r.bottom});
  return {
    kind: svg.dataset.plot,
    title: (svg.querySelector('text.title') || {}).textContent || '',
    box: box(svg.getBoundingClientRect()),
    texts: [...svg.querySelectorAll('text')].filter(t => t.textContent.trim() !== '').map(t => Object.assign(
        {text: t.textContent, cls: t.getAttribute('class') || (t.closest('g.legend') ? 'legend' : '')},
        box(t.getBoundingClientRect()))),
  };
})
"""


def text_overlaps(plot, slack=0.5):
    """The pairs of a plot's texts whose boxes intersect (by more than `slack` px each way), and the texts
    that reach outside the plot. Ring labels of a polar plot sit on its rings and spokes by design, and
    are only held to the plot's box."""
    texts = plot["texts"]
    outside = [t["text"] for t in texts if t["l"] < plot["box"]["l"] - slack or t["r"] > plot["box"]["r"] + slack
               or t["t"] < plot["box"]["t"] - slack or t["b"] > plot["box"]["b"] + slack]
    pairs = []
    for i, a in enumerate(texts):
        for b in texts[i + 1:]:
            if "ring-label" in a["cls"] or "ring-label" in b["cls"]:
                continue
            if min(a["r"], b["r"]) - max(a["l"], b["l"]) > slack and min(a["b"], b["b"]) - max(a["t"], b["t"]) > slack:
                pairs.append((a["text"], b["text"]))
    return pairs, outside


def open_self_contained(browser, html, check):
    """Loads `html` in `browser` and checks, through check(cond, msg), that it stands alone: no script,
    nothing referred to on the network, no console or load problems, no request but the page itself."""
    text = open(html, encoding="utf-8").read()
    check("<script" not in text.lower(), "%s: has a <script>" % html)
    check(not re.search(r"(src|href)\s*=\s*\"(https?:|//)", text), "%s: refers to a network resource" % html)
    browser.open("file://" + os.path.abspath(html))
    check(browser.problems() == [], "%s: console/load problems: %s" % (html, browser.problems()))
    reqs = browser.requests()
    check(len(reqs) == 1, "%s: loads more than itself: %s" % (html, reqs))


def have_chromium():
    """True when headless Chromium is installed; otherwise says so as a failure (a test that needs it fails
    without it, never skips: ./scripts/setup.sh installs it)."""
    try:
        cdp.find_chromium()
        return True
    except cdp.ChromiumMissing as e:
        print("FAIL:", e)
        return False
