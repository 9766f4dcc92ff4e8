r"""Check the built website in a real browser (headless Chromium), with no network.

Usage (after ``python tools/build_site.py``)::

    apt-get install -y chromium            # Debian/Ubuntu: the system Chromium
    python tools/check_site_browser.py     # every page of build/site/, opened as file://
    python tools/check_site_browser.py --http            # ... served from 127.0.0.1 instead
    python tools/check_site_browser.py build/site/chapters/03_damped_particle.html

Playwright (pinned in ``requirements-site.txt``) drives the system Chromium
(``--chromium``, default: the first of ``chromium``, ``chromium-browser``,
``google-chrome`` on the PATH); no browser is downloaded. Every request
that leaves the site (any URL that is neither ``file://`` nor the local
server) is blocked and reported, so the check proves that the pages work
offline. Each page is opened at a width of 1,024 px and checked for:

* **maths typeset**: MathJax loaded from the site itself, every ``.math``
  element rendered (an ``mjx-container`` inside), no TeX error
  (``mjx-merror``), and no raw ``\(``, ``\[``, ``$$`` or ``$...\...$`` left
  in the text outside code;
* **images load**: every ``<img>`` decoded with a non-zero size;
* **nothing overflows the text column**: no display equation or table is
  wider than the article column (a wide one would scroll sideways; the
  report names the equation, its section and both widths);
* no request blocked or failed, no JavaScript error.

It prints one line per page (``PASS`` or ``FAIL`` with the counts), the
details of every failure, and exits 1 if any page fails.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import shutil
import sys
import threading
from pathlib import Path
from urllib.parse import urlparse

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "build" / "site"
WIDTH, HEIGHT = 1024, 900

# Runs in the page once it has loaded; returns what the checks need.
PAGE_PROBE = r"""
async () => {
  const mathEls = [...document.querySelectorAll('.math')];
  const result = {mathCount: mathEls.length, mathjax: false, untypeset: [], errors: [],
                  raw: [], images: [], badImages: [], overflows: [], column: 0};
  if (mathEls.length) {
    for (let k = 0; k < 200 && !(window.MathJax && MathJax.startup && MathJax.startup.promise); k++)
      await new Promise(r => setTimeout(r, 50));
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
      result.mathjax = true;
      await MathJax.startup.promise;
    }
  }
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
  for (const el of mathEls) {
    if (!el.querySelector('mjx-container')) result.untypeset.push(texOf(el).slice(0, 120));
    if (el.querySelector('mjx-merror, [data-mjx-error]'))
      result.errors.push(texOf(el).slice(0, 120) + ' -> ' +
        (el.querySelector('[data-mjx-error]') || el).getAttribute('data-mjx-error'));
  }
  // Raw TeX delimiters left in the text, outside code, scripts and typeset maths.
  const skip = 'pre, code, script, style, textarea, mjx-container, .highlight, kbd';
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  const rawPattern = /\\\(|\\\[|\$\$|\$[^$\s][^$]*[\\_^][^$]*\$/;
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    if (node.parentElement && node.parentElement.closest(skip)) continue;
    const m = rawPattern.exec(node.textContent);
    if (m) result.raw.push(sectionOf(node.parentElement) + ': ' +
      node.textContent.slice(Math.max(0, m.index - 30), m.index + 60).replace(/\s+/g, ' '));
  }
  // Images: load them all (no lazy loading), then each must have a size.
  const imgs = [...document.images];
  for (const img of imgs) img.loading = 'eager';
  await Promise.all(imgs.map(img => img.decode().catch(() => null)));
  for (const img of imgs) {
    const src = img.getAttribute('src');
    result.images.push(src);
    if (!(img.complete && img.naturalWidth > 0)) result.badImages.push(src);
  }
  // Overflow of the article column at this width.
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
  return result;
}
"""


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


def serve(site: Path) -> tuple[http.server.ThreadingHTTPServer, str]:
    """Serve ``site`` on 127.0.0.1 (an ephemeral port) in a thread; returns the server and base URL."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
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


def check_pages(pages: list[Path], site: Path, chromium: str, use_http: bool) -> int:
    from playwright.sync_api import sync_playwright

    server, base = serve(site) if use_http else (None, site.resolve().as_uri() + "/")
    local_host = urlparse(base).netloc
    failures = 0
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path=chromium, headless=True,
            # no name resolution at all: nothing but file:// and the loopback server can load
            args=["--no-sandbox", "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1"])
        context = browser.new_context(viewport={"width": WIDTH, "height": HEIGHT},
                                      service_workers="block")
        for page_path in pages:
            rel = page_path.resolve().relative_to(site.resolve()).as_posix()
            blocked, failed, js_errors = [], [], []

            page = context.new_page()
            page.route("**/*", _router(blocked, local_host))
            page.on("requestfailed", lambda req, failed=failed: failed.append(
                f"{req.url} ({req.failure})"))
            page.on("pageerror", lambda exc, js_errors=js_errors: js_errors.append(str(exc)))
            page.goto(base + rel, wait_until="load")
            info = page.evaluate(PAGE_PROBE)
            page.close()
            failed = [f for f in failed if not any(f.startswith(b) for b in blocked)]
            problems = []
            if info["mathCount"] and not info["mathjax"]:
                problems.append("MathJax did not load")
            problems += [f"not typeset: {t}" for t in info["untypeset"][:10]]
            problems += [f"TeX error: {t}" for t in info["errors"][:10]]
            problems += [f"raw TeX left: {t}" for t in info["raw"][:10]]
            problems += [f"image did not load: {s}" for s in info["badImages"]]
            problems += [f"{o['kind']} overflows the {info['column']} px column by "
                         f"{o['width'] - info['column']} px ({o['width']} px) in section "
                         f"'{o['section']}': {o['tex']}" for o in info["overflows"]]
            problems += [f"blocked request (needs the network): {u}" for u in sorted(set(blocked))]
            problems += [f"failed request: {u}" for u in sorted(set(failed))]
            problems += [f"JavaScript error: {e}" for e in js_errors]
            status = "FAIL" if problems else "PASS"
            failures += bool(problems)
            typeset = info["mathCount"] - len(info["untypeset"])
            print(f"{status} {rel}: {typeset}/{info['mathCount']} maths typeset"
                  f"{' by the local MathJax' if info['mathjax'] else ''}, "
                  f"{len(info['images']) - len(info['badImages'])}/{len(info['images'])} images "
                  f"loaded, {len(info['overflows'])} overflows (column {info['column']} px)",
                  flush=True)
            for problem in problems:
                print(f"    - {problem}", flush=True)
        browser.close()
    if server:
        server.shutdown()
    print(f"{len(pages) - failures} passed, {failures} failed")
    return 1 if failures else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="check_site_browser.py",
        description="Open every page of the built site in headless Chromium with no network and "
                    "check maths, images and overflow at 1,024 px.")
    parser.add_argument("pages", nargs="*", type=Path,
                        help="pages to check (default: every .html file of build/site/)")
    parser.add_argument("--site", type=Path, default=SITE, help="the built site (default: build/site)")
    parser.add_argument("--http", action="store_true",
                        help="serve the site from 127.0.0.1 instead of opening files (file://)")
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
    return check_pages(pages, args.site, find_chromium(args.chromium), args.http)


if __name__ == "__main__":
    sys.exit(main())
