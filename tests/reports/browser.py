"""A headless Chromium for the report tests (selenium and the system's chromium and chromedriver; the test
skips without them), and the layout check of a page at a given width."""
from __future__ import annotations

import shutil
from contextlib import contextmanager
from pathlib import Path

import pytest

#: For every element that reaches beyond the page's right (or left) edge and is not inside a box that
#: scrolls sideways: its tag, id, class and left and right edges (px); then the page's width and the
#: width of its content (wider: the page itself scrolls sideways), the scroll boxes wider than the page and
#: the tables outside any scroll box.
LAYOUT = """
const page = document.documentElement.clientWidth;
const scrolls = e => { for (let p = e.parentElement; p && p !== document.body; p = p.parentElement) {
  const o = getComputedStyle(p).overflowX; if (o === 'auto' || o === 'scroll') return true; } return false; };
const out = [];
for (const e of document.body.querySelectorAll('*')) {
  const r = e.getBoundingClientRect();
  if ((r.right > page + 0.5 || r.left < -0.5) && !scrolls(e))
    out.push([e.tagName, e.id, String(e.className), Math.round(r.left), Math.round(r.right)]);
}
const boxes = Array.from(document.querySelectorAll('div.scroll'))
  .filter(b => b.getBoundingClientRect().right > page + 0.5)
  .map(b => b.querySelector('table') && b.querySelector('table').id);
const bare = Array.from(document.querySelectorAll('table')).filter(t => !t.closest('div.scroll'))
  .map(t => 'not in a scroll box: ' + t.id);
return [page, document.documentElement.scrollWidth, out, boxes.concat(bare)];
"""


def chromium():
    """selenium's webdriver, Options and Service (the test skips without selenium, chromium or chromedriver)."""
    pytest.importorskip("selenium")
    for exe in ("chromium", "chromedriver"):
        if shutil.which(exe) is None:
            pytest.skip(f"{exe} is not installed (bash .ci/install installs it)")
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    return webdriver, Options, Service


@contextmanager
def browser(profile: Path, width: int = 1300, height: int = 1000):
    """A headless Chromium window of ``width`` x ``height`` px (its profile in ``profile``), quit after."""
    webdriver, Options, Service = chromium()
    options = Options()
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run",
                f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(arg)
    options.binary_location = shutil.which("chromium")
    driver = webdriver.Chrome(options=options, service=Service(shutil.which("chromedriver")))
    try:
        driver.set_page_load_timeout(60)
        yield driver
    finally:
        driver.quit()


def check_layout(driver, page: Path, width: int, shot: Path) -> dict:
    """Open ``page`` at ``width`` px and assert that nothing is wider than the page: no element reaches
    beyond its edges unless it is inside a box that scrolls sideways, every table is in such a box and no
    such box is wider than the page, and the page itself does not scroll sideways. Saves a screenshot of
    the whole page to ``shot``; returns ``{"page": px, "figures": [ids]}``."""
    driver.set_window_size(width, 1000)
    driver.get(page.resolve().as_uri())
    inner, content, outside, boxes = driver.execute_script(LAYOUT)
    assert outside == [], (width, outside[:10])
    assert boxes == [], (width, boxes)
    assert content <= inner, (width, content, inner)
    figures = driver.execute_script("return Array.from(document.querySelectorAll('figure')).map(f => f.id)")
    height = driver.execute_script("return document.body.scrollHeight")
    driver.set_window_size(width, min(int(height) + 50, 16000))
    assert driver.save_screenshot(str(shot))
    return {"page": inner, "figures": figures}
