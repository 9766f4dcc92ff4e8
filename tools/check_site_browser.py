r"""Check the built website in a real browser (headless Chromium), with no network.

Usage (after ``python tools/build_site.py``)::

    apt-get install -y chromium            # Debian/Ubuntu: the system Chromium
    python tools/check_site_browser.py --http     # every page, served from 127.0.0.1 (as CI)
    python tools/check_site_browser.py            # ... opened as files (file://) instead
    python tools/check_site_browser.py build/site/chapters/03_damped_particle.html --widths 390
    python tools/check_site_browser.py --http --print 02 06   # also print two chapters to PDF

Playwright (pinned in ``requirements-site.txt``) drives the system Chromium
(``--chromium``, default: the first of ``chromium``, ``chromium-browser``,
``google-chrome`` on the PATH); no browser is downloaded. Every request
that leaves the site (any URL that is neither ``file://`` nor the local
server) is blocked and reported, so the check proves that the pages work
offline. Each page is opened at each width (default 390, 1,024 and 1,440 px:
a phone, a small laptop, a desktop) and checked for:

* **maths typeset**: MathJax loaded from the site itself, every ``.math``
  element rendered (an ``mjx-container`` inside), no TeX error
  (``mjx-merror``), and, once MathJax has run, **no ``$`` and no
  ``\command``** in the visible text outside maths and code (a stray ``$``
  or raw ``\Sigma`` means a formula was not read as maths);
* **images**: every ``<img>`` loads; every figure of a chapter has alt text
  (not empty, not its file name) and is a link to its full-size image;
* **no page-level sideways scroll** at any width: the page is never wider
  than the window (the report names the widest elements if it is);
* **nothing overflows the text column** at 1,024 px and wider: no display
  equation or table is wider than the article column. At 390 px a wide
  equation scrolls inside its own box: it is listed, not failed;
* **code lines whole** at 1,024 px and wider: a probe code cell holding an
  88-character line (the course's limit) does not scroll; a real code cell
  that scrolls is a failure if its longest line has at most 88 characters,
  and is listed (the notebook's line is too long) otherwise;
* **no request blocked or failed, no JavaScript error**, and no console
  error: over http every console error fails the page; opened as files,
  console errors are listed (the browser's own file:// restrictions) but
  only those on the search page fail it;
* **search** (once per run): ``search.html?q=Kalman`` lists results; over
  http each has a snippet taken from the page's article, without TeX; as
  files the results come without snippets and without console errors.

``--print NN ...`` prints those chapters with the print stylesheet (print
media, A4) to ``build/site-pdf/NN.pdf`` and checks that no code block is
cut (in print media every ``pre`` fits its box, the site's header and
sidebars are hidden) and, with ``pdftotext`` (poppler-utils) on the PATH,
that every code line of the page is in the PDF's text whole.

It prints one line per page and width (``PASS`` or ``FAIL`` with the
counts), the details of every failure, the notes (what the notebooks should
fix), and exits 1 if anything fails.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from urllib.parse import urlparse

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "build" / "site"
PDF_DIR = ROOT / "build" / "site-pdf"
WIDTHS = (390, 1024, 1440)
HEIGHT = 900
CODE_LIMIT = 88   # characters per code line (CONTRIBUTING, tools/chapter_metrics.py)

# Runs in the page once it has loaded; returns what the checks need. Argument: the code limit.
PAGE_PROBE = r"""
async (codeLimit) => {
  const mathEls = [...document.querySelectorAll('.math')];
  const result = {mathCount: mathEls.length, mathjax: false, untypeset: [], errors: [],
                  stray: [], images: [], badImages: [], badAlt: [], unlinked: [], overflows: [],
                  column: 0, pageWidth: 0, window: window.innerWidth, widest: [],
                  code: {probe: null, site: [], long: []}};
  if (mathEls.length) {
    for (let k = 0; k < 200 && !(window.MathJax && MathJax.startup && MathJax.startup.promise); k++)
      await new Promise(r => setTimeout(r, 50));
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
      result.mathjax = true;
      await MathJax.startup.promise;
    }
  }
  if (window.bayesfiltMarkWideInlineMaths) window.bayesfiltMarkWideInlineMaths();
  const texOf = el => {
    try {
      const items = MathJax.startup.document.getMathItemsWithin(el);
      if (items.length) return items[0].math;
    } catch (e) {}
    return (el.textContent || '').slice(0, 200);
  };
  const sectionOf = el => {
    let s = el.closest('section');
    while (s) {
      const h = s.querySelector(':scope > h1, :scope > h2, :scope > h3, :scope > h4');
      if (h) return h.textContent.replace(/#$/, '').trim();
      s = s.parentElement && s.parentElement.closest('section');
    }
    return '(top of page)';
  };
  const cellOf = el => {
    const cells = [...document.querySelectorAll('.bd-article div.cell, .bd-article section')];
    const cell = el.closest('div.cell');
    return cell ? ` (code cell ${cells.filter(c => c.matches('div.cell')).indexOf(cell) + 1})` : '';
  };
  for (const el of mathEls) {
    if (!el.querySelector('mjx-container')) result.untypeset.push(texOf(el).slice(0, 120));
    if (el.querySelector('mjx-merror, [data-mjx-error]'))
      result.errors.push(texOf(el).slice(0, 120) + ' -> ' +
        (el.querySelector('[data-mjx-error]') || el).getAttribute('data-mjx-error'));
  }
  // Stray TeX: a `$` or a `\command` in the visible text outside maths, code and scripts.
  const skip = 'pre, code, kbd, samp, script, style, textarea, mjx-container, .math, .highlight, ' +
               'mjx-assistive-mml, [aria-hidden="true"] mjx-container';
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const strayPattern = /\$|\\[A-Za-z]+/;
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    const parent = node.parentElement;
    if (!parent || parent.closest(skip)) continue;
    const m = strayPattern.exec(node.textContent);
    if (m) result.stray.push(sectionOf(parent) + ': …' +
      node.textContent.slice(Math.max(0, m.index - 40), m.index + 50).replace(/\s+/g, ' ') + '…');
  }
  // Images: load them all (no lazy loading), then each must have a size.
  const imgs = [...document.images];
  for (const img of imgs) img.loading = 'eager';
  await Promise.all(imgs.map(img => img.decode().catch(() => null)));
  for (const img of imgs) {
    const src = img.getAttribute('src');
    result.images.push(src);
    if (!(img.complete && img.naturalWidth > 0)) result.badImages.push(src);
    if (img.closest('.bd-article div.cell_output')) {
      const alt = (img.getAttribute('alt') || '').trim();
      const file = src.split('/').pop();
      if (!alt || alt === src || (alt.includes('/') && !alt.includes(' ')) || alt === file ||
          /\.(png|jpe?g|svg|gif)$/i.test(alt))
        result.badAlt.push(`${sectionOf(img)}${cellOf(img)}: alt=${JSON.stringify(alt.slice(0, 60))}`);
      const link = img.closest('a');
      if (!link || link.getAttribute('href').split('/').pop() !== file)
        result.unlinked.push(`${sectionOf(img)}${cellOf(img)}: ${file}`);
    }
  }
  // Page-level sideways scroll, and the elements that stick out of the window.
  result.pageWidth = Math.max(document.documentElement.scrollWidth, document.body.scrollWidth);
  if (result.pageWidth > window.innerWidth + 1) {
    const out = [];
    for (const el of document.body.querySelectorAll('*')) {
      const r = el.getBoundingClientRect();
      if (r.width && r.right > window.innerWidth + 1 && ![...el.children].some(c =>
            c.getBoundingClientRect().right > window.innerWidth + 1)) {
        let hidden = false;  // inside a box that scrolls or clips: not the page's problem
        for (let a = el.parentElement; a && a !== document.body; a = a.parentElement) {
          const ox = getComputedStyle(a).overflowX;
          if (ox !== 'visible') { hidden = true; break; }
        }
        if (!hidden) out.push(`<${el.tagName.toLowerCase()}${el.className && typeof el.className === 'string' ?
          ' class="' + el.className.slice(0, 40) + '"' : ''}> right edge ${Math.round(r.right)} px in '` +
          sectionOf(el) + "': " + (el.textContent || '').replace(/\s+/g, ' ').trim().slice(0, 70));
      }
    }
    result.widest = out.slice(0, 8);
  }
  // The article column and what overflows it.
  const article = document.querySelector('article.bd-article') || document.querySelector('main') ||
                  document.body;
  const style = getComputedStyle(article);
  const box = article.getBoundingClientRect();
  const left = box.left + parseFloat(style.paddingLeft);
  const right = box.right - parseFloat(style.paddingRight);
  result.column = Math.round(right - left);
  const tol = 1;
  for (const c of article.querySelectorAll('mjx-container[display="true"]')) {
    const inner = c.querySelector('mjx-math') || c;
    const r = inner.getBoundingClientRect();
    if (r.width > right - left + tol || r.right > right + tol || r.left < left - tol)
      result.overflows.push({kind: 'equation', section: sectionOf(c), width: Math.round(r.width),
                             tex: texOf(c.closest('.math') || c).replace(/\s+/g, ' ').slice(0, 160)});
  }
  for (const t of article.querySelectorAll('table')) {
    const r = t.getBoundingClientRect();
    const wide = Math.max(t.scrollWidth, r.width);
    if (wide > right - left + tol || r.right > right + tol)
      result.overflows.push({kind: 'table', section: sectionOf(t), width: Math.round(wide),
        tex: (t.querySelector('tr') || t).textContent.replace(/\s+/g, ' ').trim().slice(0, 160)});
  }
  // Code: a probe cell with one line of codeLimit characters, then the real code cells.
  const sample = article.querySelector('div.cell_input div.highlight pre') ||
                 article.querySelector('div.highlight pre');
  if (sample) {
    const host = sample.closest('div.cell') || sample.closest('div[class*="highlight-"]');
    const clone = host.cloneNode(true);
    const pre = clone.querySelector('div.highlight pre');
    pre.textContent = 'x = f(' + 'a'.repeat(codeLimit - 7) + ')';
    host.parentElement.insertBefore(clone, host);
    const range = document.createRange();
    range.selectNodeContents(pre);
    const ps = getComputedStyle(pre);
    result.code.probe = {chars: pre.textContent.length, scroll: pre.scrollWidth, client: pre.clientWidth,
                         fontSize: ps.fontSize, text: Math.round(range.getBoundingClientRect().width),
                         room: Math.round(pre.clientWidth - parseFloat(ps.paddingLeft) -
                                          parseFloat(ps.paddingRight))};
    clone.remove();
  }
  for (const pre of article.querySelectorAll('div.cell_input div.highlight pre, ' +
                                             'div[class*="highlight-"]:not(.output) div.highlight pre')) {
    if (pre.scrollWidth <= pre.clientWidth + 1) continue;
    const longest = Math.max(...pre.textContent.split('\n').map(l => l.length));
    const line = pre.textContent.split('\n').find(l => l.length === longest);
    const entry = `${sectionOf(pre)}${cellOf(pre)}: ${longest} characters: ${line.trim().slice(0, 60)}…`;
    (longest > codeLimit ? result.code.long : result.code.site).push(entry);
  }
  return result;
}
"""

# The search page: waits for the results; returns them with their snippets.
SEARCH_PROBE = r"""
async () => {
  for (let k = 0; k < 200; k++) {
    const status = document.querySelector('#search-results .search-summary, #search-results p');
    if (status && document.querySelectorAll('#search-results ul.search li').length &&
        !document.querySelector('#search-results h2')?.textContent.includes('Searching')) break;
    await new Promise(r => setTimeout(r, 50));
  }
  await new Promise(r => setTimeout(r, 1500));   // snippets are fetched after the list
  return [...document.querySelectorAll('#search-results ul.search li')].map(li => ({
    title: (li.querySelector('a') || li).textContent.trim(),
    object: li.classList.contains('kind-object'),   // an API entry: its description, no snippet
    snippet: (li.querySelector('p.context') || {textContent: null}).textContent}));
}
"""

# In print media: hidden chrome, and code that fits its box.
PRINT_PROBE = r"""
() => {
  const visible = sel => [...document.querySelectorAll(sel)].filter(e => {
    const s = getComputedStyle(e); return s.display !== 'none' && s.visibility !== 'hidden' &&
      e.getBoundingClientRect().height > 0; }).length;
  const cut = [];
  const lines = [];
  for (const pre of document.querySelectorAll('article.bd-article div.highlight pre')) {
    if (pre.scrollWidth > pre.clientWidth + 1)
      cut.push(pre.textContent.split('\n')[0].slice(0, 60));
    if (pre.closest('div.cell_input'))
      lines.push(...pre.textContent.split('\n').filter(l => l.trim()));
  }
  return {chrome: visible('.bd-header, .bd-sidebar-primary, .bd-sidebar-secondary, ' +
                          '.article-header-buttons, .prev-next-area, .copybtn'),
          cut, lines};
}
"""

# Text the theme puts around the article: a snippet that holds it starts in the chrome.
CHROME_WORDS = ("Skip to main content", "Ctrl+K", "Print / PDF", "Notebook (.ipynb)",
                "Launch", "Back to top", "Contents", "Search Results")


def find_chromium(given: str | None) -> str:
    for name in ([given] if given else ["chromium", "chromium-browser", "google-chrome"]):
        path = shutil.which(name) or (name if name and Path(name).is_file() else None)
        if path:
            return path
    raise SystemExit("error: no Chromium found; install it (apt-get install -y chromium) or give "
                     "--chromium PATH")


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # noqa: D401 - keep the report readable
        pass


class _QuietServer(http.server.ThreadingHTTPServer):
    def handle_error(self, request, client_address):
        """A page closed while a file was still being sent (BrokenPipe): not worth a traceback."""
        if not isinstance(sys.exc_info()[1], (BrokenPipeError, ConnectionResetError)):
            super().handle_error(request, client_address)


def serve(site: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    """Serve ``site`` on 127.0.0.1 (an ephemeral port) in a thread; returns the server and base URL."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = _QuietServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


def _router(blocked: list[str], local_host: str):
    """A route handler: local requests go through, every other one is aborted and recorded."""

    def route(r):
        parsed = urlparse(r.request.url)
        if parsed.scheme in ("file", "data", "blob", "about") or parsed.netloc == local_host:
            r.continue_()
        else:
            blocked.append(r.request.url)
            r.abort()

    return route


class Session:
    """One browser context at one width, with the site's base URL and request bookkeeping."""

    def __init__(self, browser, base: str, width: int):
        self.context = browser.new_context(viewport={"width": width, "height": HEIGHT},
                                           service_workers="block")
        self.base = base
        self.local_host = urlparse(base).netloc

    def open(self, rel: str):
        """Open a page; returns it with lists of blocked and failed requests, JS and console errors."""
        log = {"blocked": [], "failed": [], "js": [], "console": []}
        page = self.context.new_page()
        page.route("**/*", _router(log["blocked"], self.local_host))
        page.on("requestfailed", lambda req: log["failed"].append(f"{req.url} ({req.failure})"))
        page.on("pageerror", lambda exc: log["js"].append(str(exc)))
        page.on("console", lambda msg: log["console"].append(msg.text)
                if msg.type == "error" else None)
        page.goto(self.base + rel, wait_until="load")
        return page, log


def request_problems(log: dict) -> list[str]:
    failed = [f for f in log["failed"] if not any(f.startswith(b) for b in log["blocked"])]
    return ([f"blocked request (needs the network): {u}" for u in sorted(set(log["blocked"]))]
            + [f"failed request: {u}" for u in sorted(set(failed))]
            + [f"JavaScript error: {e}" for e in log["js"]])


def check_page(session: Session, rel: str, width: int, use_http: bool) -> tuple[list, list, str]:
    """Check one page at one width: (problems, notes, summary line)."""
    page, log = session.open(rel)
    info = page.evaluate(PAGE_PROBE, CODE_LIMIT)
    page.close()
    problems, notes = [], []
    if info["mathCount"] and not info["mathjax"]:
        problems.append("MathJax did not load")
    problems += [f"not typeset: {t}" for t in info["untypeset"][:10]]
    problems += [f"TeX error: {t}" for t in info["errors"][:10]]
    problems += [f"stray TeX in the text (a `$` or `\\command` outside maths): {t}"
                 for t in info["stray"][:10]]
    problems += [f"image did not load: {s}" for s in info["badImages"]]
    problems += [f"figure without alt text (empty or its file name): {s}" for s in info["badAlt"]]
    problems += [f"figure not linked to its full-size image: {s}" for s in info["unlinked"]]
    if info["pageWidth"] > info["window"] + 1:
        problems.append(f"the page scrolls sideways: {info['pageWidth']} px wide in a "
                        f"{info['window']} px window; sticking out: " + ("; ".join(info["widest"])
                                                                       or "(nothing found)"))
    overflow_lines = [f"{o['kind']} wider than the {info['column']} px column ({o['width']} px) in "
                      f"section '{o['section']}': {o['tex']}" for o in info["overflows"]]
    if width >= 1024:
        problems += overflow_lines
        probe = info["code"]["probe"]
        if probe and (probe["scroll"] > probe["client"] + 1 or probe["text"] > probe["room"] + 1):
            problems.append(f"an {probe['chars']}-character code line does not fit its cell "
                            f"({probe['scroll']} px in {probe['client']} px at {probe['fontSize']})")
        problems += [f"code cell scrolls though its lines are ≤ {CODE_LIMIT} characters: {c}"
                     for c in info["code"]["site"]]
        notes += [f"code line over {CODE_LIMIT} characters (the notebook's or docstring's): {c}"
                  for c in info["code"]["long"]]
    else:
        notes += [f"scrolls inside its own box at {width} px: {line}" for line in overflow_lines]
    problems += request_problems(log)
    if log["console"]:
        if use_http or rel.startswith("search"):
            problems += [f"console error: {e}" for e in log["console"]]
        else:
            notes += [f"console error (file://): {e}" for e in log["console"]]
    typeset = info["mathCount"] - len(info["untypeset"])
    probe = info["code"]["probe"]
    summary = (f"{rel} @{width}px: {typeset}/{info['mathCount']} maths typeset"
               f"{' by the local MathJax' if info['mathjax'] else ''}, "
               f"{len(info['images']) - len(info['badImages'])}/{len(info['images'])} images, "
               f"page {info['pageWidth']} px, column {info['column']} px"
               + (f", an {probe['chars']}-character code line takes {probe['text']} of "
                  f"{probe['room']} px" if probe and width >= 1024 else ""))
    return problems, notes, summary


def check_search(session: Session, use_http: bool) -> tuple[list, str]:
    """Search the site for "Kalman": results, and over http snippets from the article."""
    page, log = session.open("search.html?q=Kalman")
    results = page.evaluate(SEARCH_PROBE)
    page.close()
    problems = request_problems(log) + [f"console error: {e}" for e in log["console"]]
    if not results:
        problems.append("searching for 'Kalman' lists no page")
    pages = [r for r in results if not r["object"]]
    snippets = [r["snippet"] for r in pages if r["snippet"] is not None]
    if use_http:
        if len(snippets) < len(pages):
            problems.append(f"{len(pages) - len(snippets)} of {len(pages)} page results have no snippet")
        for r in results:
            text = r["snippet"] or ""
            if re.search(r"\$|\\[A-Za-z]+", text):
                problems.append(f"snippet with TeX for '{r['title']}': {text[:120]}")
            chrome = [w for w in CHROME_WORDS if w in text]
            if chrome:
                problems.append(f"snippet from the page's chrome ({chrome}) for '{r['title']}': "
                                f"{text[:120]}")
    if not use_http and snippets:
        problems.append(f"{len(snippets)} results have a snippet opened as files: the pages were fetched")
    summary = (f"search 'Kalman': {len(results)} results ({len(pages)} pages, "
               f"{len(results) - len(pages)} API entries), {len(snippets)} with a snippet"
               + ("" if use_http else " (file://: no snippets, by design)"))
    return problems, summary


def check_print(browser, base: str, site: Path, chapters: list[str], out_dir: Path) -> list[str]:
    """Print chapters to PDF in print media; every code line whole. Returns the problems."""
    problems = []
    pdftotext = shutil.which("pdftotext")
    context = browser.new_context(viewport={"width": 1024, "height": HEIGHT})
    out_dir.mkdir(parents=True, exist_ok=True)
    for number in chapters:
        pages = sorted((site / "chapters").glob(f"{number}_*.html"))
        if not pages:
            problems.append(f"print: no chapter {number}")
            continue
        rel = pages[0].relative_to(site).as_posix()
        page = context.new_page()
        page.route("**/*", _router([], urlparse(base).netloc))
        page.goto(base + rel, wait_until="load")
        page.evaluate("async () => { if (window.MathJax && MathJax.startup) "
                      "await MathJax.startup.promise; }")
        page.emulate_media(media="print")
        info = page.evaluate(PRINT_PROBE)
        pdf = out_dir / f"{pages[0].stem}.pdf"
        page.pdf(path=str(pdf), format="A4", print_background=True,
                 margin={"top": "15mm", "bottom": "15mm", "left": "15mm", "right": "15mm"})
        page.close()
        found = []
        if info["chrome"]:
            found.append(f"{info['chrome']} elements of the site's chrome are printed")
        found += [f"a code block is cut in print: {c}" for c in info["cut"]]
        missing = []
        if pdftotext:
            # A line is whole if either reading order of the PDF's text holds it: -layout
            # keeps a far-right end-of-line comment on its line, but can interleave it
            # with a display equation just above the cell; -raw keeps the order of
            # drawing, which is the code block's own.
            flats = [re.sub(r"\s+", "", subprocess.run(
                [pdftotext, mode, "-enc", "UTF-8", str(pdf), "-"],
                capture_output=True, text=True, check=True).stdout)
                for mode in ("-layout", "-raw")]
            missing = [line for line in info["lines"]
                       if not any(re.sub(r"\s+", "", line) in flat for flat in flats)]
            found += [f"code line not whole in the PDF: {line.strip()[:80]}" for line in missing[:10]]
        pages_count = len(re.findall(rb"/Type\s*/Page[^s]", pdf.read_bytes()))
        print(f"{'FAIL' if found else 'PASS'} print {rel}: {pdf.relative_to(ROOT) if pdf.is_relative_to(ROOT) else pdf}"
              f" ({pages_count} pages), {len(info['lines'])} code lines, "
              + (f"{len(info['lines']) - len(missing)} whole in the PDF's text"
                 if pdftotext else "pdftotext not found: PDF text not checked"), flush=True)
        for problem in found:
            print(f"    - {problem}", flush=True)
        problems += found
    context.close()
    return problems


def check_pages(pages: list[Path], site: Path, chromium: str, use_http: bool,
                widths: tuple[int, ...] = WIDTHS, print_chapters: list[str] | None = None,
                search: bool = True) -> int:
    from playwright.sync_api import sync_playwright

    server, base = serve(site) if use_http else (None, site.resolve().as_uri() + "/")
    failures, checks, all_notes = 0, 0, []
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=chromium, headless=True,
            # no name resolution at all: nothing but file:// and the loopback server can load
            args=["--no-sandbox", "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"])
        for width in widths:
            session = Session(browser, base, width)
            for page_path in pages:
                rel = page_path.resolve().relative_to(site.resolve()).as_posix()
                problems, notes, summary = check_page(session, rel, width, use_http)
                checks += 1
                failures += bool(problems)
                print(f"{'FAIL' if problems else 'PASS'} {summary}", flush=True)
                for problem in problems:
                    print(f"    - {problem}", flush=True)
                all_notes += [f"{rel} @{width}px: {n}" for n in notes]
            session.context.close()
        if search:
            problems, summary = check_search(Session(browser, base, 1024), use_http)
            checks += 1
            failures += bool(problems)
            print(f"{'FAIL' if problems else 'PASS'} {summary}", flush=True)
            for problem in problems:
                print(f"    - {problem}", flush=True)
        if print_chapters:
            problems = check_print(browser, base, site, print_chapters, PDF_DIR)
            checks += len(print_chapters)
            failures += bool(problems)
        browser.close()
    if server:
        server.shutdown()
    if all_notes:
        print(f"\nNotes ({len(all_notes)}; not failures: for the chapters' writers):")
        for note in all_notes:
            print(f"    {note}")
    print(f"{checks - failures} passed, {failures} failed")
    return 1 if failures else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="check_site_browser.py",
        description="Open every page of the built site in headless Chromium with no network and "
                    "check maths, images, sideways scroll, code lines, console errors and search at "
                    "390, 1,024 and 1,440 px.")
    parser.add_argument("pages", nargs="*", type=Path,
                        help="pages to check (default: every .html file of build/site/)")
    parser.add_argument("--site", type=Path, default=SITE, help="the built site (default: build/site)")
    parser.add_argument("--http", action="store_true",
                        help="serve the site from 127.0.0.1 instead of opening files (file://)")
    parser.add_argument("--widths", type=int, nargs="+", default=list(WIDTHS), metavar="PX",
                        help="window widths in px (default: 390 1024 1440)")
    parser.add_argument("--print", dest="print_chapters", nargs="+", metavar="NN",
                        help="also print these chapters to PDF (build/site-pdf/) and check the code")
    parser.add_argument("--no-search", action="store_true", help="skip the search check")
    parser.add_argument("--chromium", help="the Chromium executable (default: found on the PATH)")
    args = parser.parse_args(argv)
    if not (args.site / "index.html").is_file():
        print(f"error: no site in {args.site}; build it first: python tools/build_site.py",
              file=sys.stderr)
        return 2
    try:
        import playwright  # noqa: F401
    except ImportError:
        print("error: playwright is missing: pip install -r requirements-site.txt", file=sys.stderr)
        return 2
    # every page; _static/ holds the theme's template fragments, _sources/_downloads no pages
    pages = args.pages or sorted(
        page for page in args.site.rglob("*.html")
        if page.relative_to(args.site).parts[0] not in ("_static", "_sources", "_downloads"))
    return check_pages(pages, args.site, find_chromium(args.chromium), args.http,
                       tuple(args.widths), args.print_chapters, not args.no_search)


if __name__ == "__main__":
    sys.exit(main())
