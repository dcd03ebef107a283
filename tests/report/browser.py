"""Open a page in headless Chromium and report what a reader's browser would see.

Talks the Chrome DevTools Protocol over ``--remote-debugging-pipe`` (NUL-terminated JSON
on file descriptors 3 and 4), so it needs no websocket library and no driver: only a
Chromium binary. ``find_chromium()`` looks for one that is already there (``$SHOCKDYNO_CHROMIUM``,
the PATH, Playwright's browser cache) and is None without one: nothing is ever installed
(``make test`` must not change the system). ``python3 tests/report/browser.py`` prints the
one line ``make test`` shows: the browser found, or how to enable the browser tests.
"""

from __future__ import annotations

import contextlib
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
from typing import Any

NAMES = (
    "chromium",
    "chromium-browser",
    "google-chrome",
    "google-chrome-stable",
    "chrome",
    "chrome-headless-shell",
    "headless_shell",
)
ENV = "SHOCKDYNO_CHROMIUM"  # a browser binary to use, named by the user
# Playwright's own downloads (`playwright install chromium`), where a machine may have one.
PLAYWRIGHT = (
    "chromium-*/chrome-linux*/chrome",
    "chromium_headless_shell-*/chrome-linux*/headless_shell",
    "chromium_headless_shell-*/chrome-headless-shell-linux*/chrome-headless-shell",
)
HOW_TO_ENABLE = (
    f"browser tests skipped: no Chromium found (set {ENV}=/path/to/chrome, or put chromium "
    "or google-chrome on the PATH; make test installs nothing)"
)

# Open every collapsed block and load every image now (lazy images in closed <details>
# would otherwise never load), then report each image's state.
PROBE = """
(async () => {
  document.querySelectorAll('details').forEach(d => { d.open = true; });
  const imgs = Array.from(document.images);
  imgs.forEach(i => { i.loading = 'eager'; });
  await Promise.all(imgs.map(i => i.complete ? null :
      new Promise(r => { i.addEventListener('load', r); i.addEventListener('error', r); })));
  return {images: imgs.map(i => ({src: i.getAttribute('src'),
                                  ok: i.complete && i.naturalWidth > 0,
                                  width: i.naturalWidth})),
          scrollWidth: document.documentElement.scrollWidth};
})()
"""

SETTLE = """
(async () => {
  const t0 = Date.now();
  while (Date.now() - t0 < 2000 && !Array.from(document.images).every(i => i.complete))
    await new Promise(r => setTimeout(r, 50));
})()
"""

# Under print media: the navigation's display and how figures and tables break.
PRINT_STYLES = """
(() => {
  const style = (sel, prop) => {
    const el = document.querySelector(sel);
    return el ? getComputedStyle(el).getPropertyValue(prop) : null; };
  return {nav: style('nav', 'display'), figure: style('figure', 'break-inside'),
          table: style('table', 'break-inside')};
})()
"""


def find_chromium() -> str | None:
    """A Chromium already on this machine: ``$SHOCKDYNO_CHROMIUM`` (only it, when set),
    else the first of NAMES on the PATH, else Playwright's cache; None without one."""
    given = os.environ.get(ENV, "").strip()
    if given:
        path = shutil.which(given)
        return path if path else None
    for name in NAMES:
        path = shutil.which(name)
        if path:
            return path
    cache = Path(
        os.environ.get("PLAYWRIGHT_BROWSERS_PATH") or Path.home() / ".cache" / "ms-playwright"
    )
    for pattern in PLAYWRIGHT:
        for found in sorted(cache.glob(pattern), reverse=True):  # the newest build first
            if os.access(found, os.X_OK):
                return str(found)
    return None


@dataclass
class PageReport:
    images: list[dict[str, Any]] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)  # script exceptions, console errors
    failed_loads: list[str] = field(default_factory=list)  # network requests that failed
    screenshot: bytes = b""
    page_height_px: int = 0
    scroll_width_px: int = 0  # wider than the window: the page scrolls sideways
    pdf: bytes = b""  # the page printed (print_pdf), as a reader's print-to-PDF makes it
    print_styles: dict[str, str] = field(default_factory=dict)  # computed under print media
    requests: list[str] = field(default_factory=list)  # every URL the page asked for
    evaluated: Any = None  # what open_page's `evaluate` expression returned


class _Pipe:
    def __init__(self, proc: subprocess.Popen[bytes], write_fd: int, read_fd: int) -> None:
        self.proc, self.write_fd, self.read_fd = proc, write_fd, read_fd
        self.buffer = b""
        self.next_id = 0
        self.events: list[dict[str, Any]] = []

    def send(self, method: str, params: dict[str, Any] | None = None, session: str = "") -> int:
        self.next_id += 1
        msg: dict[str, Any] = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self.write_fd, json.dumps(msg).encode() + b"\0")
        return self.next_id

    def _read(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self.buffer:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("chromium did not answer")
            ready, _, _ = select.select([self.read_fd], [], [], left)
            if ready:
                chunk = os.read(self.read_fd, 1 << 20)
                if not chunk:
                    raise RuntimeError("chromium closed the pipe")
                self.buffer += chunk
        raw, _, self.buffer = self.buffer.partition(b"\0")
        return dict(json.loads(raw))

    def call(
        self, method: str, params: dict[str, Any] | None = None, session: str = "", timeout=30.0
    ) -> dict[str, Any]:
        wanted = self.send(method, params, session)
        deadline = time.monotonic() + timeout
        while True:
            msg = self._read(deadline)
            if msg.get("id") == wanted:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return dict(msg.get("result", {}))
            self.events.append(msg)

    def wait_event(self, method: str, timeout: float = 30.0) -> dict[str, Any]:
        for i, ev in enumerate(self.events):
            if ev.get("method") == method:
                return self.events.pop(i)
        deadline = time.monotonic() + timeout
        while True:
            msg = self._read(deadline)
            if msg.get("method") == method:
                return msg
            self.events.append(msg)


def open_page(
    chromium: str,
    page: Path,
    width: int = 800,
    screenshot: bool = False,
    print_pdf: bool = False,
    evaluate: str = "",
    media: str = "",
) -> PageReport:
    """Load ``page`` at ``width`` CSS pixels; collect images, errors, optionally a full-page
    screenshot (PNG bytes). ``print_pdf``: print it to PDF as loaded, without the probe
    (which opens every block itself), so the PDF shows what the page's own print does.
    ``evaluate``: a JS expression (a promise is awaited) run after the probe, its value in
    ``evaluated``; ``media``: emulate it ("print")."""
    to_chrome_r, to_chrome_w = os.pipe()
    from_chrome_r, from_chrome_w = os.pipe()

    with tempfile.TemporaryDirectory(prefix="shockdyno-chromium-") as profile:
        # The protocol's fixed descriptors 3 (in) and 4 (out) are set up in a small Python
        # launcher rather than a preexec_fn, which is unsafe in a threaded process (and a
        # shell's redirections cannot name descriptors above 9 everywhere).
        launcher = (
            "import os, sys; os.dup2(int(sys.argv[1]), 3); os.dup2(int(sys.argv[2]), 4); "
            "os.execv(sys.argv[3], sys.argv[3:])"
        )
        proc = subprocess.Popen(
            [sys.executable, "-c", launcher, str(to_chrome_r), str(from_chrome_w),
             chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--disable-extensions", "--hide-scrollbars", "--remote-debugging-pipe",
             f"--user-data-dir={profile}", "about:blank"],
            pass_fds=(to_chrome_r, from_chrome_w),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )  # fmt: skip
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        pipe = _Pipe(proc, to_chrome_w, from_chrome_r)
        try:
            return _inspect(pipe, page, width, screenshot, print_pdf, evaluate, media)
        finally:
            with contextlib.suppress(OSError):
                pipe.send("Browser.close")
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            os.close(to_chrome_w)
            os.close(from_chrome_r)


def _inspect(
    pipe: _Pipe,
    page: Path,
    width: int,
    screenshot: bool,
    print_pdf: bool,
    evaluate: str,
    media: str,
) -> PageReport:
    target = pipe.call("Target.createTarget", {"url": "about:blank"})["targetId"]
    session = pipe.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
    for domain in ("Page", "Runtime", "Log", "Network"):
        pipe.call(f"{domain}.enable", session=session)
    pipe.call(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": 900, "deviceScaleFactor": 1, "mobile": False},
        session=session,
    )
    if media:
        pipe.call("Emulation.setEmulatedMedia", {"media": media}, session=session)
    pipe.call("Page.navigate", {"url": page.resolve().as_uri()}, session=session)
    pipe.wait_event("Page.loadEventFired")
    if print_pdf:
        import base64

        # A reader opens the page and prints it a moment later: wait (up to 2 s) until
        # every image has loaded, or has not started and will not without a scroll.
        pipe.call("Runtime.evaluate", {"expression": SETTLE, "awaitPromise": True},
                  session=session, timeout=10.0)  # fmt: skip
        pipe.call("Emulation.setEmulatedMedia", {"media": "print"}, session=session)
        styles = pipe.call(
            "Runtime.evaluate",
            {"expression": PRINT_STYLES, "returnByValue": True},
            session=session,
        )
        pipe.call("Emulation.setEmulatedMedia", {"media": ""}, session=session)
        printed = pipe.call(
            "Page.printToPDF", {"paperWidth": 8.27, "paperHeight": 11.69}, session=session,
            timeout=60.0,
        )  # fmt: skip
        return PageReport(
            pdf=base64.b64decode(printed["data"]),
            print_styles=dict(styles.get("result", {}).get("value") or {}),
        )
    probe = pipe.call(
        "Runtime.evaluate",
        {"expression": PROBE, "awaitPromise": True, "returnByValue": True},
        session=session,
    )
    value = probe.get("result", {}).get("value") or {}
    report = PageReport(
        images=list(value.get("images", [])), scroll_width_px=int(value.get("scrollWidth", 0))
    )
    if "exceptionDetails" in probe:
        report.errors.append(f"probe failed: {probe['exceptionDetails']}")
    if evaluate:
        done = pipe.call(
            "Runtime.evaluate",
            {"expression": evaluate, "awaitPromise": True, "returnByValue": True},
            session=session,
        )
        if "exceptionDetails" in done:
            report.errors.append(f"evaluate failed: {done['exceptionDetails']}")
        report.evaluated = done.get("result", {}).get("value")
    if screenshot:
        import base64

        metrics = pipe.call("Page.getLayoutMetrics", session=session)
        height = int(metrics["cssContentSize"]["height"])
        report.page_height_px = height
        shot = pipe.call(
            "Page.captureScreenshot",
            {"format": "png", "captureBeyondViewport": True,
             "clip": {"x": 0, "y": 0, "width": width, "height": height, "scale": 1}},
            session=session,
            timeout=60.0,
        )  # fmt: skip
        report.screenshot = base64.b64decode(shot["data"])
    pipe.call("Runtime.evaluate", {"expression": "1"}, session=session)  # drain pending events
    for ev in pipe.events:
        method, params = ev.get("method"), ev.get("params", {})
        if method == "Runtime.exceptionThrown":
            details = params.get("exceptionDetails", {})
            report.errors.append(str(details.get("exception", {}).get("description") or details))
        elif method == "Runtime.consoleAPICalled" and params.get("type") == "error":
            report.errors.append(" ".join(str(a.get("value")) for a in params.get("args", [])))
        elif method == "Log.entryAdded" and params.get("entry", {}).get("level") == "error":
            report.errors.append(str(params["entry"].get("text")))
        elif method == "Network.requestWillBeSent":
            report.requests.append(str(params.get("request", {}).get("url")))
        elif method == "Network.loadingFailed":
            report.failed_loads.append(str(params.get("errorText")))
    return report


if __name__ == "__main__":  # `make test` prints this line before the tests run
    found = find_chromium()
    print(f"browser tests: {found}" if found else HOW_TO_ENABLE)
