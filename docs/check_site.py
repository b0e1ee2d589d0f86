"""Check the built site as a reader sees it, in headless Chromium without a network.

Usage (after ``python -m sphinx -b html docs docs/_build/html``)::

    python docs/check_site.py [docs/_build/html]

Every HTML page of the build is opened from disk (``file://``) in one headless
Chromium, driven by Selenium through Debian's ``chromium-driver``, with every
host name resolving to nothing, so that an asset only a CDN serves fails. On
every page it checks that

- no request failed (Chrome's network log) and nothing went to the network;
- the console logged no error;
- every image loaded (its natural width is positive);
- the math rendered: MathJax typeset every formula without an error, and no
  raw TeX (a backslash command, ``_{`` or ``^{``) is left in the text outside
  code;
- no code block is wider than its box (no line hidden behind a scrollbar) at
  1280 px.

It writes screenshots at 1280 px width of the home page, a guide page, a gallery
page and an API page into ``<build>/_screenshots/`` for a reviewer, prints one
line per page with a problem and exits with status 1 if any page has one, 0 if
none has. Where Chromium or its driver is not installed it says so and exits
with status 0 (nothing was checked); ``--require-browser`` makes that status 2.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

WIDTH, HEIGHT = 1280, 900
SCREENSHOTS = {
    "home": "index.html",
    "guide": "user_guide/methods.html",
    "gallery": "auto_examples/chirp_spectrogram.html",
    "api": "generated/ltvmodels.fit.html",
}

# Runs in the page: waits for MathJax (only where the page has math), then
# reports what a reader would see broken. Selenium's async script: the last
# argument is the callback.
PAGE_PROBE = r"""
const done = arguments[arguments.length - 1];
async function probe() {
    const hasMath = document.querySelector(".math") !== null;
    let mathjax = "none";
    if (hasMath) {
        const start = Date.now();
        while (!(window.MathJax && MathJax.startup && MathJax.startup.promise)) {
            if (Date.now() - start > 10000) break;
            await new Promise(r => setTimeout(r, 50));
        }
        if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
            await MathJax.startup.promise;
            mathjax = "done";
        } else {
            mathjax = "not loaded";
        }
    }
    for (const img of document.images) {
        if (!img.complete) await new Promise(r => { img.onload = img.onerror = r; });
    }
    const brokenImages = Array.from(document.images)
        .filter(img => img.naturalWidth === 0)
        .map(img => img.getAttribute("src"));
    const mathErrors = Array.from(document.querySelectorAll("mjx-merror, [data-mjx-error]"))
        .map(el => el.getAttribute("data-mjx-error") || el.textContent);
    const unrendered = Array.from(document.querySelectorAll(".math"))
        .filter(el => el.querySelector("mjx-container") === null && !el.matches("mjx-container"))
        .map(el => el.textContent.trim().slice(0, 60));
    // Code wider than its box hides behind a horizontal scrollbar.
    const clipped = Array.from(document.querySelectorAll("main pre"))
        .filter(el => el.scrollWidth > el.clientWidth + 1)
        .map(el => el.textContent.split("\n").reduce((a, b) => (b.length > a.length ? b : a), ""));
    // The text a reader sees outside code: no TeX may be left in it.
    const main = (document.querySelector("main") || document.documentElement).cloneNode(true);
    main.querySelectorAll("pre, code, script, style, mjx-container, .highlight, kbd, samp")
        .forEach(el => el.remove());
    const tex = /\\[A-Za-z]+|\\[()\[\]]|[_^]\{/g;
    const rawTex = Array.from(new Set(main.textContent.match(tex) || []));
    done({mathjax, hasMath, brokenImages, mathErrors, unrendered, rawTex, clipped});
}
probe().catch(err => done({error: String(err)}));
"""


def _driver(chromium: str, chromedriver: str):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for argument in [
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        f"--window-size={WIDTH},{HEIGHT}",
        # No network: every host name resolves to nothing, so a CDN asset fails.
        "--host-resolver-rules=MAP * ~NOTFOUND",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ]:
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(chromedriver))
    driver.set_page_load_timeout(30)
    driver.set_script_timeout(30)
    # Belt and braces: the DevTools protocol blocks every non-file URL as well.
    driver.execute_cdp_cmd("Network.enable", {})
    driver.execute_cdp_cmd(
        "Network.setBlockedURLs", {"urls": ["http://*", "https://*", "ws://*", "wss://*"]}
    )
    return driver


def _network_problems(driver) -> list[str]:
    """Failed requests and requests that left the disk, from Chrome's network log."""
    problems = []
    urls: dict[str, str] = {}
    for entry in driver.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        method, params = message.get("method"), message.get("params", {})
        if method == "Network.requestWillBeSent":
            url = params["request"]["url"]
            urls[params["requestId"]] = url
            if not url.startswith(("file:", "data:", "blob:", "about:")):
                problems.append(f"request to the network: {url}")
        elif method == "Network.loadingFailed" and not params.get("canceled"):
            url = urls.get(params["requestId"], "?")
            if not url.startswith(("http:", "https:")):  # those are reported above
                problems.append(f"failed request: {url} ({params.get('errorText')})")
    return problems


def _console_errors(driver) -> list[str]:
    return [
        f"console error: {entry['message']}"
        for entry in driver.get_log("browser")
        if entry["level"] == "SEVERE"
    ]


def check_page(driver, page: Path) -> list[str]:
    """Open one page and return its problems (an empty list: none)."""
    driver.get(page.as_uri())
    result = driver.execute_async_script(PAGE_PROBE)
    problems = []
    if "error" in result:
        problems.append(f"the page probe failed: {result['error']}")
    else:
        if result["hasMath"] and result["mathjax"] != "done":
            problems.append(f"MathJax {result['mathjax']}")
        problems += [f"image not loaded: {src}" for src in result["brokenImages"]]
        problems += [f"formula with an error: {text}" for text in result["mathErrors"]]
        problems += [f"formula not typeset: {text}" for text in result["unrendered"]]
        problems += [f"code line clipped: {line.strip()[:60]}" for line in result["clipped"]]
        if result["rawTex"]:
            problems.append(f"raw TeX in the text: {' '.join(result['rawTex'][:8])}")
    problems += _network_problems(driver)
    problems += _console_errors(driver)
    return list(dict.fromkeys(problems))  # a resource fails once per reference to it


def screenshot(driver, page: Path, target: Path) -> None:
    """A full-page screenshot at the window's width (1280 px)."""
    driver.get(page.as_uri())
    driver.execute_async_script(PAGE_PROBE)
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(WIDTH, min(max(int(height), HEIGHT), 8000))
    time.sleep(0.2)  # the resize's layout
    driver.save_screenshot(str(target))
    driver.set_window_size(WIDTH, HEIGHT)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", nargs="?", default="docs/_build/html", type=Path)
    parser.add_argument(
        "--require-browser",
        action="store_true",
        help="exit with status 2 instead of 0 where Chromium is not installed",
    )
    args = parser.parse_args(argv)
    build = args.build.resolve()
    if not (build / "index.html").is_file():
        print(f"error: build: no index.html in {str(build)!r}; build the site", file=sys.stderr)
        return 2
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    chromedriver = shutil.which("chromedriver")
    try:
        import selenium  # noqa: F401
    except ImportError:
        chromium = None
    if chromium is None or chromedriver is None:
        print(
            "site check skipped: Chromium, chromedriver or selenium is not installed "
            "(apt-get install chromium chromium-driver; pip install selenium)"
        )
        return 2 if args.require_browser else 0

    pages = sorted(p for p in build.rglob("*.html") if "_static" not in p.parts)
    shots = build / "_screenshots"
    shots.mkdir(exist_ok=True)
    start = time.perf_counter()
    driver = _driver(chromium, chromedriver)
    failed = 0
    try:
        for page in pages:
            problems = check_page(driver, page)
            if problems:
                failed += 1
                print(f"{page.relative_to(build)}:")
                for problem in problems:
                    print(f"    {problem}")
        for name, relative in SCREENSHOTS.items():
            if (build / relative).is_file():
                screenshot(driver, build / relative, shots / f"{name}.png")
            else:
                failed += 1
                print(f"{relative}: missing (no screenshot)")
    finally:
        driver.quit()
    seconds = time.perf_counter() - start
    print(f"site check: {len(pages)} pages, {failed} with problems ({seconds:.1f} s)")
    print(f"screenshots: {', '.join(sorted(p.name for p in shots.glob('*.png')))} in {shots}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
