"""Headless Chromium for the replay page tests, and the README's screenshot of the page.

Chromium and its driver come from Debian packages (``apt-get install chromium
chromium-driver``; ``.ci/run`` installs them); selenium drives them. Both paths
are given explicitly, so selenium-manager never tries to download a browser.

The README's and docs/views.md's screenshots of the page are made by
``python docs/pictures.py replay`` through :func:`screenshot`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from typing import Any, Iterator

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-dev-shm-usage", "--window-size=1500,900",
)  # fmt: skip


def chromium_present() -> bool:
    try:
        import selenium  # noqa: F401
    except ImportError:
        return False
    return all(os.access(p, os.X_OK) for p in (CHROMIUM, CHROMEDRIVER))


@contextlib.contextmanager
def chromium() -> Iterator[Any]:
    """A selenium Chrome driver on Debian's Chromium, with a fresh profile that is removed afterwards."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="btgen-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def screenshot(page: Any, png: str, tick: int = 12, search: str = "", window: tuple[int, int] = (1400, 820)) -> None:
    """Open the replay page *page* (a path) in a *window*-sized Chromium, step to *tick* (0: the first) with
    the keyboard, find *search* in the tree, and save a screenshot as *png*."""
    import pathlib

    with chromium() as driver:
        driver.set_window_size(*window)
        driver.get(pathlib.Path(page).resolve().as_uri())
        body = driver.find_element("tag name", "body")
        body.send_keys("\ue011")  # Home: tick 0
        for _ in range(tick):
            body.send_keys("\ue014")  # →
        if search:
            driver.find_element("id", "search").send_keys(search + "\ue007")  # Enter
        driver.save_screenshot(png)
