"""Render pages of the built documentation in headless Chromium.

    python scripts/render_docs.py docs/_build/html [--out docs/_build/png]

loads the front page and the API page of ``geoalpha.hull`` in Debian's
``chromium`` (headless), writes a PNG of each, and prints each page's title,
headings and any console errors, failed requests or uncaught exceptions. It
exits with status 1 when a page reports one.

The browser is driven through the Chrome DevTools Protocol over a pipe
(``--remote-debugging-pipe``: JSON messages separated by NUL bytes on file
descriptors 3 and 4), so nothing beyond the standard library and the browser is
needed. ``tests/test_docs.py`` uses :func:`load_page` from this file.
"""

from __future__ import annotations

import argparse
import base64
import fcntl
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

PAGES = {
    "index": "index.html",
    "api_hull": "api/generated/geoalpha.hull.html",
}

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--remote-debugging-pipe",
]

HEADINGS_JS = (
    "JSON.stringify(Array.from(document.querySelectorAll('article h1, article h2'))"
    ".map(e => e.textContent.replace(/[#¶]/g, '').trim()))"
)


def find_chromium() -> str | None:
    """Path of the Chromium binary (``$CHROMIUM`` first), or None."""
    for name in (os.environ.get("CHROMIUM"), "chromium", "chromium-browser"):
        if name and (found := shutil.which(name)):
            return found
    return None


@dataclass
class Page:
    """What a page showed and reported once loaded."""

    url: str
    title: str = ""
    headings: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    png: bytes = b""


class _Browser:
    """A headless Chromium and one DevTools session over its pipe."""

    def __init__(self, binary: str, timeout: float):
        self.timeout = timeout
        self._profile = tempfile.mkdtemp(prefix="geoalpha-chromium-")
        # Chromium reads commands on fd 3 and writes replies and events on fd 4.
        # The child's ends are first moved above fd 10, so that putting them
        # on 3 and 4 cannot overwrite one with the other.
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        child_r = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD_CLOEXEC, 10)
        child_w = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD_CLOEXEC, 10)
        for fd in (to_browser_r, from_browser_w):
            os.close(fd)

        def child_pipes() -> None:  # runs in the child, before exec
            os.dup2(child_r, 3)  # dup2's copies are inherited, the rest not
            os.dup2(child_w, 4)

        self._proc = subprocess.Popen(
            [binary, *FLAGS, f"--user-data-dir={self._profile}", "about:blank"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            close_fds=False,  # keeps 3 and 4; Python's own fds are non-inheritable
            preexec_fn=child_pipes,
        )
        os.close(child_r)
        os.close(child_w)
        self._buffer = b""
        self._next_id = 0
        self.events: list[dict] = []

    def close(self) -> None:
        try:
            self.send("Browser.close")
        except (OSError, TimeoutError, RuntimeError):
            pass
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait(timeout=10)
        for fd in (self._to_browser, self._from_browser):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self._profile, ignore_errors=True)

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no answer from Chromium in time")
            ready, _, _ = select.select([self._from_browser], [], [], left)
            if ready:
                chunk = os.read(self._from_browser, 1 << 20)
                if not chunk:
                    raise RuntimeError("Chromium closed its DevTools pipe")
                self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def send(self, method: str, session: str | None = None, **params) -> dict:
        """Send one command and return its result (events are kept meanwhile)."""
        self._next_id += 1
        message = {"id": self._next_id, "method": method, "params": params}
        if session:
            message["sessionId"] = session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + self.timeout
        while True:
            reply = self._read_message(deadline)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_for(self, method: str) -> dict:
        """Wait for an event (one already received counts)."""
        deadline = time.monotonic() + self.timeout
        while True:
            for event in self.events:
                if event.get("method") == method:
                    return event
            self.events.append(self._read_message(deadline))


def _errors(events: list[dict]) -> list[str]:
    """Console errors, failed requests and uncaught exceptions among events."""
    found = []
    for event in events:
        method, params = event.get("method"), event.get("params", {})
        if method == "Runtime.consoleAPICalled" and params.get("type") in (
            "error",
            "assert",
        ):
            args = params["args"]
            text = " ".join(str(a.get("value", a.get("description"))) for a in args)
            found.append(f"console.{params['type']}: {text}")
        elif method == "Runtime.exceptionThrown":
            details = params.get("exceptionDetails", {})
            exception = details.get("exception", {})
            text = exception.get("description") or details.get("text")
            found.append(f"uncaught exception: {text}")
        elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
            entry = params["entry"]
            where = entry.get("url", "")
            found.append(f"{entry.get('source')}: {entry.get('text')} {where}")
        elif method == "Network.loadingFailed" and not params.get("canceled"):
            found.append(f"request failed: {params.get('errorText')}")
    return found


def load_page(
    path: str | Path,
    *,
    binary: str | None = None,
    width: int = 1280,
    height: int = 900,
    screenshot: bool = True,
    timeout: float = 60.0,
) -> Page:
    """Load a local HTML file in headless Chromium and report what it shows.

    Parameters
    ----------
    path : str or Path
        The HTML file.
    binary : str, optional
        The Chromium binary (default: :func:`find_chromium`).
    width, height : int
        Size of the window, in CSS pixels.
    screenshot : bool
        Also take a PNG of the window.
    timeout : float
        Seconds to wait for any one answer of the browser.

    Returns
    -------
    Page
        Title, ``h1``/``h2`` headings of the article, errors, and the PNG.
    """
    binary = binary or find_chromium()
    if binary is None:
        raise FileNotFoundError("no chromium binary found (apt-get install chromium)")
    url = Path(path).resolve().as_uri()
    browser = _Browser(binary, timeout)
    try:
        target = browser.send("Target.createTarget", url="about:blank")["targetId"]
        session = browser.send("Target.attachToTarget", targetId=target, flatten=True)[
            "sessionId"
        ]
        for domain in ("Page", "Runtime", "Log", "Network"):
            browser.send(f"{domain}.enable", session)
        browser.send(
            "Emulation.setDeviceMetricsOverride",
            session,
            width=width,
            height=height,
            deviceScaleFactor=1,
            mobile=False,
        )
        browser.events.clear()
        browser.send("Page.navigate", session, url=url)
        browser.wait_for("Page.loadEventFired")
        # Let the theme's scripts that run after load (and their errors) finish.
        browser.send(
            "Runtime.evaluate",
            session,
            expression="new Promise(r => setTimeout(r, 300))",
            awaitPromise=True,
        )
        page = Page(url=url)
        page.title = browser.send(
            "Runtime.evaluate", session, expression="document.title"
        )["result"]["value"]
        page.headings = json.loads(
            browser.send("Runtime.evaluate", session, expression=HEADINGS_JS)["result"][
                "value"
            ]
        )
        if screenshot:
            data = browser.send("Page.captureScreenshot", session, format="png")
            page.png = base64.b64decode(data["data"])
        page.errors = _errors(browser.events)
        return page
    finally:
        browser.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("html", type=Path, help="the built site, docs/_build/html")
    parser.add_argument("--out", type=Path, help="PNG folder (default: HTML/../png)")
    args = parser.parse_args(argv)
    out = args.out or args.html.parent / "png"
    out.mkdir(parents=True, exist_ok=True)
    status = 0
    for name, relative in PAGES.items():
        page = load_page(args.html / relative)
        png = out / f"{name}.png"
        png.write_bytes(page.png)
        print(f"{png}: {page.title!r}, headings {page.headings}")
        for error in page.errors:
            print(f"  error: {error}")
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
