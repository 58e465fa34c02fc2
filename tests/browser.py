"""A headless Chromium driven by Selenium for the HTML view's tests, or the reason there is none.

The browser comes from the operating system's packages (``scripts/install-browser.sh``
installs Debian's ``chromium`` and ``chromium-driver``); ``$CHROMIUM`` and ``$CHROMEDRIVER``
name other binaries.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
WINDOW = (1400, 1000)  # px: the view's full height with its legend


def find_browser() -> tuple[str, str] | str:
    """(browser, driver) paths, or why there are none."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[test]')"
    browser = os.environ.get("CHROMIUM") or next(
        (p for p in map(shutil.which, BROWSERS) if p), None)
    driver = os.environ.get("CHROMEDRIVER") or shutil.which("chromedriver")
    if browser is None or driver is None or not all(map(os.path.isfile, (browser, driver))):
        return ("no headless Chromium and chromedriver found (scripts/install-browser.sh "
                "installs Debian's; or set $CHROMIUM and $CHROMEDRIVER)")
    return browser, driver


@contextmanager
def chromium(browser: str, driver: str) -> Iterator[Any]:
    """A headless Chromium session keeping the page's console log; always quit."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = browser
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                f"--window-size={WINDOW[0]},{WINDOW[1]}", "--hide-scrollbars"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    session = webdriver.Chrome(service=Service(driver), options=options)
    try:
        yield session
    finally:
        session.quit()


WAIT_FOR_PLOT = """
const done = arguments[arguments.length - 1];
const until = Date.now() + 20000;
(function poll() {
  const gd = document.getElementById('mission-view');
  if (gd && gd._fullLayout && gd.querySelector('.main-svg') && gd._transitionData
      && gd._transitionData._frames && gd._transitionData._frames.length) done(true);
  else if (Date.now() > until) done(false);
  else setTimeout(poll, 10);
})();
"""
