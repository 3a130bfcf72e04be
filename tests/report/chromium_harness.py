"""Headless Chromium for the report tests, driven from Python over the DevTools protocol on a pipe.

Debian's `chromium` (installed by `.ci/run`) is started once with `--remote-debugging-pipe`: it reads
protocol commands from file descriptor 3 and writes replies and events to file descriptor 4, each message
JSON ending in a NUL byte. No Playwright, Selenium or websocket library: subprocess, os.pipe and json.

Why the protocol rather than `--dump-dom` and `--screenshot` with `--enable-logging=stderr`: Chromium's
stderr log prints every console message the same way (`INFO:CONSOLE:<line>`) whatever its level, and does
not print failed loads (a missing image file) at all. The protocol reports each console call with its
level, uncaught exceptions, and the browser's own errors (`Log.entryAdded`, e.g. `net::ERR_FILE_NOT_FOUND`),
runs the image check in the page, and takes full-page screenshots with real phone emulation.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import queue
import shutil
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

MISSING = "chromium not found: .ci/run installs it (apt-get install chromium)"
#: Longest wait for one protocol reply or page load (s); a hang fails the test instead of stalling CI.
TIMEOUT_S = 60.0
#: Device pixels per CSS pixel of the emulated phone (real ones have 2 to 3): its screenshots are as sharp
#: as the phone's screen, so that what is illegible there looks illegible here and no more.
PHONE_PIXEL_RATIO = 2
#: Tallest screenshot (CSS px): a runaway page must not make a gigabyte PNG.
MAX_SHOT_HEIGHT_PX = 16000

#: Runs in the page after `load`: every <img>, whether it loaded and decodes, with its natural size.
IMAGE_CHECK = """
(async () => {
  const out = [];
  for (const [i, img] of Array.from(document.images).entries()) {
    let decodes = false, error = "";
    try { await img.decode(); decodes = true; } catch (e) { error = String(e); }
    out.push({index: i, alt: img.alt, src: img.currentSrc.slice(0, 80), complete: img.complete,
              naturalWidth: img.naturalWidth, naturalHeight: img.naturalHeight,
              shownWidth: img.width, shownHeight: img.height, decodes: decodes, error: error});
  }
  return out;
})()
"""
#: The page's layout after load: whether anything is wider than the viewport.
LAYOUT_CHECK = """
(() => {
  const vw = document.documentElement.clientWidth;
  const wide = [];
  for (const el of document.querySelectorAll("body *")) {
    const r = el.getBoundingClientRect();
    if (r.right > vw + 1) wide.push(el.tagName.toLowerCase() + " " + Math.round(r.right));
  }
  const root = document.documentElement;
  return {viewportWidth: vw, initialScale: window.visualViewport.scale, scrollWidth: root.scrollWidth,
          scrollHeight: root.scrollHeight, tooWide: wide.slice(0, 10),
          fontPx: parseFloat(getComputedStyle(document.body).fontSize)};
})()
"""


class ChromiumError(AssertionError):
    """The browser could not be driven (not a finding about the page)."""


def chromium_executable() -> str:
    """Debian's chromium; an AssertionError (a test failure, never a skip) if it is not installed."""
    found = shutil.which("chromium")
    if found is None:
        raise AssertionError(MISSING)
    return found


@dataclass
class PageResult:
    """What one load of one page showed."""

    url: str
    width: int
    mobile: bool
    pixel_ratio: float = 1.0
    console_errors: list[str] = field(default_factory=list)
    images: list[dict] = field(default_factory=list)
    layout: dict = field(default_factory=dict)
    screenshot: Path | None = None

    @property
    def broken_images(self) -> list[dict]:
        return [i for i in self.images if not (i["complete"] and i["naturalWidth"] > 0 and i["decodes"])]


class Chromium:
    """One headless Chromium; `load()` opens a page in a new tab and reports on it. Use as a context."""

    def __init__(self, executable: str | None = None) -> None:
        exe = executable or chromium_executable()
        self._profile = tempfile.TemporaryDirectory(prefix="swarm-chromium-")
        self._stderr = open(Path(self._profile.name) / "stderr.log", "w+b")  # noqa: SIM115 (closed in close)
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        args = [
            "--headless=new",
            "--remote-debugging-pipe",
            "--no-sandbox",  # CI runs as root
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-extensions",
            "--hide-scrollbars",
            "--mute-audio",
            f"--user-data-dir={self._profile.name}/profile",
            "about:blank",
        ]
        # Chromium wants the pipe on fds 3 (in) and 4 (out). bash moves them there by way of two numbers
        # above both (either may be 3 or 4 already), closes the rest, and execs the browser.
        r, w = to_browser_r, from_browser_w
        a, b = max(r, w) + 1, max(r, w) + 2
        script = f'exec {a}<&{r} {b}>&{w} {r}<&- {w}>&-; exec "$0" "$@" 3<&{a} 4>&{b} {a}<&- {b}>&-'
        self._proc = subprocess.Popen(
            [shutil.which("bash") or "/bin/bash", "-c", script, exe, *args],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=self._stderr,
            pass_fds=(to_browser_r, from_browser_w),
        )
        os.close(to_browser_r)
        os.close(from_browser_w)
        self._messages: queue.Queue[dict | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._next_id = 0
        self._events: list[dict] = []
        self.version = self._call("Browser.getVersion")["product"]

    # --- the protocol -----------------------------------------------------------------------------------
    def _read(self) -> None:
        buffer = b""
        while True:
            try:
                chunk = os.read(self._from_browser, 1 << 16)
            except OSError:
                chunk = b""
            if not chunk:
                self._messages.put(None)
                return
            buffer += chunk
            *complete, buffer = buffer.split(b"\0")
            for raw in complete:
                self._messages.put(json.loads(raw))

    def stderr_tail(self, lines: int = 20) -> str:
        """The browser's last stderr lines, without the noise of a machine with no D-Bus."""
        self._stderr.flush()
        text = (Path(self._profile.name) / "stderr.log").read_text(errors="replace").splitlines()
        return "\n".join([line for line in text if "dbus" not in line][-lines:]) or "(nothing)"

    def _next(self, deadline: float) -> dict:
        try:
            message = self._messages.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            raise ChromiumError(
                f"chromium did not answer in {TIMEOUT_S:.0f} s; its stderr:\n{self.stderr_tail()}"
            ) from None
        if message is None:
            raise ChromiumError(
                f"chromium exited (code {self._proc.poll()}); its stderr:\n{self.stderr_tail()}"
            )
        return message

    def _call(self, method: str, session: str | None = None, **params: object) -> dict:
        self._next_id += 1
        message: dict = {"id": self._next_id, "method": method, "params": params}
        if session is not None:
            message["sessionId"] = session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + TIMEOUT_S
        while True:
            reply = self._next(deadline)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise ChromiumError(f"{method}: {reply['error']}")
                return reply["result"]
            self._events.append(reply)

    def _wait_event(self, method: str, session: str) -> dict:
        deadline = time.monotonic() + TIMEOUT_S
        for i, event in enumerate(self._events):
            if event.get("method") == method and event.get("sessionId") == session:
                return self._events.pop(i)
        while True:
            event = self._next(deadline)
            if event.get("method") == method and event.get("sessionId") == session:
                return event
            self._events.append(event)

    def _evaluate(self, expression: str, session: str) -> object:
        result = self._call(
            "Runtime.evaluate", session, expression=expression, awaitPromise=True, returnByValue=True
        )
        if "exceptionDetails" in result:
            raise ChromiumError(f"page script failed: {result['exceptionDetails']}")
        return result["result"]["value"]

    # --- pages ------------------------------------------------------------------------------------------
    def load(
        self, path: Path, width: int, *, mobile: bool = False, screenshot: Path | None = None
    ) -> PageResult:
        """Open `path` in a fresh tab `width` CSS px wide (`mobile`: a phone, which honours or lacks a
        viewport meta tag as a real one does), wait for `load`, collect console errors, check every image
        and, if asked, write a full-page PNG screenshot."""
        url = Path(path).resolve().as_uri()
        ratio = PHONE_PIXEL_RATIO if mobile else 1.0
        target = self._call("Target.createTarget", url="about:blank")["targetId"]
        session = self._call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        try:
            for domain in ("Page", "Runtime", "Log"):
                self._call(f"{domain}.enable", session)
            self._call(
                "Emulation.setDeviceMetricsOverride",
                session,
                width=width,
                height=900 if not mobile else 844,
                deviceScaleFactor=ratio,
                mobile=mobile,
            )
            navigation = self._call("Page.navigate", session, url=url)
            if "errorText" in navigation:
                raise AssertionError(f"chromium could not open {url}: {navigation['errorText']}")
            self._wait_event("Page.loadEventFired", session)
            page = PageResult(url=url, width=width, mobile=mobile, pixel_ratio=ratio)
            page.images = self._evaluate(IMAGE_CHECK, session)  # type: ignore[assignment]
            page.layout = self._evaluate(LAYOUT_CHECK, session)  # type: ignore[assignment]
            if screenshot is not None:
                page.screenshot = self._screenshot(session, screenshot, width, mobile)
            self._call("Runtime.evaluate", session, expression="0")  # flush events queued so far
            page.console_errors = self._console_errors(session)
            return page
        finally:
            self._call("Target.closeTarget", targetId=target)
            self._events = [e for e in self._events if e.get("sessionId") not in (session, None)]

    def _screenshot(self, session: str, out: Path, width: int, mobile: bool) -> Path:
        """The whole page; on a phone zoomed out to the screen's width as the phone shows it at first."""
        size = self._call("Page.getLayoutMetrics", session)["cssContentSize"]
        scale = min(1.0, width / size["width"]) if mobile else 1.0
        clip = {
            "x": 0,
            "y": 0,
            "width": size["width"],
            "height": min(size["height"], MAX_SHOT_HEIGHT_PX / scale),
            "scale": scale,
        }
        shot = self._call(
            "Page.captureScreenshot", session, format="png", captureBeyondViewport=True, clip=clip
        )
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(base64.b64decode(shot["data"]))
        return out

    def _console_errors(self, session: str) -> list[str]:
        """Console messages at error level, uncaught exceptions, and the browser's own errors."""
        errors = []
        for event in self._events:
            if event.get("sessionId") != session:
                continue
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.consoleAPICalled" and params["type"] in ("error", "assert"):
                text = " ".join(str(a.get("value", a.get("description", ""))) for a in params["args"])
                errors.append(f"console.{params['type']}: {text}")
            elif method == "Runtime.exceptionThrown":
                details = params["exceptionDetails"]
                text = details.get("exception", {}).get("description") or details.get("text", "")
                errors.append(f"uncaught: {text} (line {details.get('lineNumber', 0) + 1})")
            elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
                entry = params["entry"]
                errors.append(f"{entry['source']}: {entry['text']} {entry.get('url', '')}".strip())
        return errors

    # --- lifetime ---------------------------------------------------------------------------------------
    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._call("Browser.close")
        try:
            self._proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        with contextlib.suppress(OSError):
            os.close(self._to_browser)
        self._reader.join(timeout=5)
        with contextlib.suppress(OSError):
            os.close(self._from_browser)
        self._stderr.close()
        self._profile.cleanup()

    def __enter__(self) -> Chromium:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
