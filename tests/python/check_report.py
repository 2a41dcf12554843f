"""Opens `simulate --report` HTML files in headless Chromium (Playwright,
Debian's /usr/bin/chromium or $TRUSS_CHROMIUM) and checks what a person
would see:

- no console error, no page error, no request but the file itself;
- the 3D canvas draws: at the first and at the last frame it is not uniform,
  and the two differ;
- moving the slider (keyboard, as a person does) changes the frame: the
  displayed time and the canvas;
- clicking a plot moves the slider;
- the latch table lists every latch of the summary JSON's `locks`, with its
  time.

Usage: check_report.py REPORT.html SUMMARY.json [REPORT.html SUMMARY.json ...]
       [--screenshot PNG] [--screenshot-time T] (of the first report, at its
       last frame or at the frame nearest T s)
Exit 0 when every check passes, 1 with the failures listed, 3 when Playwright
or Chromium is missing (the caller decides whether that is a skip).
"""

import json
import os
import pathlib
import sys
import time

FLAGS = [
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--no-sandbox",
    "--disable-dev-shm-usage",
]


def canvas_png(page):
    return page.locator("#viewport canvas").screenshot()


def pixel_stats(page, png):
    """(distinct colours among sampled pixels, hash) of a PNG, decoded by the browser."""
    import base64

    b64 = base64.b64encode(png).decode()
    return page.evaluate(
        """async (b64) => {
            const img = new Image();
            img.src = 'data:image/png;base64,' + b64;
            await img.decode();
            const c = document.createElement('canvas');
            c.width = img.width; c.height = img.height;
            const g = c.getContext('2d');
            g.drawImage(img, 0, 0);
            const d = g.getImageData(0, 0, c.width, c.height).data;
            const seen = new Set();
            for (let i = 0; i < d.length; i += 4 * 7) seen.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
            return seen.size;
        }""",
        b64,
    )


def check(browser, report, summary, failures, shot=None):
    name = pathlib.Path(report).name
    fail = lambda msg: failures.append(f"{name}: {msg}")
    url = pathlib.Path(report).resolve().as_uri()
    page = browser.new_page(viewport={"width": 1300, "height": 1400})
    errors, requests = [], []
    page.on(
        "console",
        lambda m: errors.append(f"console {m.type}: {m.text}")
        if m.type in ("error", "assert")
        else None,
    )
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url}"))

    def route(r):
        requests.append(r.request.url)
        if r.request.url == url:
            r.continue_()
        else:
            r.abort()

    page.route("**/*", route)
    page.goto(url)
    # ready, or an error first (no waiting out the timeout on a broken page)
    deadline = time.monotonic() + 60
    while not page.evaluate("document.body !== null && document.body.dataset.ready === '1'"):
        if errors or time.monotonic() > deadline:
            fail(f"the page did not get ready: {'; '.join(errors[:5]) or 'timed out after 60 s'}")
            page.close()
            return
        page.wait_for_timeout(100)
    others = [u for u in requests if u != url]
    if others:
        fail(f"requests other than the file itself: {others[:5]}")
    frames = page.evaluate("window.trussReport.frames")
    if frames < 2:
        fail(f"{frames} frame(s)")
    slider = page.locator("#slider")
    slider.focus()
    page.keyboard.press("Home")
    page.wait_for_timeout(300)
    t0 = page.locator("#time").inner_text()
    first = canvas_png(page)
    page.keyboard.press("End")
    page.wait_for_timeout(300)
    t1 = page.locator("#time").inner_text()
    last = canvas_png(page)
    if shot:
        png, at = shot
        if at is not None:
            page.evaluate("(t) => window.trussReport.showFrame(window.trussReport.nearest(t))", at)
            page.wait_for_timeout(300)
        page.screenshot(path=png, full_page=False, clip={"x": 0, "y": 0, "width": 1300, "height": 1000})
        page.keyboard.press("End")
        page.wait_for_timeout(200)
    if page.evaluate("window.trussReport.frame()") != frames - 1:
        fail("End on the slider did not go to the last frame")
    if t0 == t1:
        fail(f"the displayed time did not change with the slider: {t0!r}")
    if first == last:
        fail("the canvas is the same at the first and the last frame")
    for which, png in (("first", first), ("last", last)):
        colours = pixel_stats(page, png)
        if colours < 8:
            fail(f"the canvas at the {which} frame is blank or uniform ({colours} colours)")
    # a step of the slider: one frame on, time and canvas change
    page.keyboard.press("Home")
    page.keyboard.press("ArrowRight")
    page.wait_for_timeout(200)
    if page.evaluate("window.trussReport.frame()") != 1:
        fail("ArrowRight on the slider did not go to frame 2")
    if page.locator("#time").inner_text() == t0:
        fail("the displayed time did not change from frame 1 to frame 2")
    # a click in the middle of a plot moves the slider there
    over = page.locator("#plots .u-over").first
    if over.count() == 0:
        fail("no plot")
    else:
        box = over.bounding_box()
        page.mouse.click(box["x"] + box["width"] * 0.5, box["y"] + box["height"] * 0.5)
        page.wait_for_timeout(200)
        f = page.evaluate("window.trussReport.frame()")
        if f in (0, 1):
            fail(f"a click in the middle of a plot left the slider at frame {f + 1}")
        if int(slider.input_value()) != f:
            fail("the slider does not show the frame a plot click chose")
    n_plots = page.locator("#plots .plot").count()
    if n_plots < 2:
        fail(f"{n_plots} plot(s); expected cable tension, latch forces and energy")
    # play: the frame advances by itself
    page.keyboard.press("Home")
    page.locator("#play").click()
    page.wait_for_timeout(1500)
    page.locator("#play").click()
    if page.evaluate("window.trussReport.frame()") == 0:
        fail("play did not advance the frame")
    # the latch table against the summary's locks
    locks = json.loads(pathlib.Path(summary).read_text())["locks"]
    rows = page.evaluate(
        """() => [...document.querySelectorAll('#latches tbody tr')].map(
            tr => [tr.dataset.latch, tr.children[1].textContent])"""
    )
    table = {n: t for n, t in rows}
    for lk in locks:
        if lk["name"] not in table:
            fail(f"latch {lk['name']} of the summary is not in the table")
        elif table[lk["name"]] in ("", "not latched") or abs(float(table[lk["name"]]) - lk["time_s"]) > 1e-5:
            fail(f"latch {lk['name']}: the table says {table[lk['name']]!r}, the summary {lk['time_s']}")
    if not locks:
        fail("the summary has no locks (the bundled models latch)")
    stats = page.evaluate("document.querySelectorAll('#solver-stats tbody tr').length")
    if stats < 5:
        fail(f"the solver counters table has {stats} rows")
    if not page.locator("#stop-message").inner_text().strip():
        fail("no stop message")
    page.wait_for_timeout(200)
    if errors:
        fail("; ".join(errors[:5]))
    print(f"{name}: {frames} frames, {len(rows)} latches, {n_plots} plots, times {t0} .. {t1}")
    page.close()


def main(argv):
    shot, at = None, None
    if "--screenshot-time" in argv:
        i = argv.index("--screenshot-time")
        at = float(argv[i + 1])
        del argv[i : i + 2]
    if "--screenshot" in argv:
        i = argv.index("--screenshot")
        shot = (argv[i + 1], at)
        del argv[i : i + 2]
    if len(argv) < 2 or len(argv) % 2:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        from playwright.sync_api import sync_playwright
    except ImportError as e:
        print(f"MISSING: playwright for Python ({e})", file=sys.stderr)
        return 3
    exe = os.environ.get("TRUSS_CHROMIUM", "/usr/bin/chromium")
    if not os.path.exists(exe):
        print(f"MISSING: chromium at {exe}", file=sys.stderr)
        return 3
    failures = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=FLAGS)
        for k in range(0, len(argv), 2):
            check(browser, argv[k], argv[k + 1], failures, shot if k == 0 else None)
        browser.close()
    for f in failures:
        print("FAIL:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
