"""A small driver of headless Chromium over the DevTools protocol, for looking at the HTML reports
as a person would: load a page, collect its console errors, uncaught exceptions and network
requests, evaluate JavaScript in it and take screenshots.

It needs a Chromium on PATH (``chromium`` or ``chromium-browser``, or ``FEMUPDATE_CHROMIUM``) and
the ``websocket-client`` package; :func:`find_chromium` says why not when either is missing.
Chromium is launched headless, without sandbox, GPU, first-run or background networking, with a
fresh profile folder that is removed afterwards; it never downloads anything.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-default-apps", "--disable-extensions", "--hide-scrollbars", "--mute-audio")


def find_chromium() -> tuple[str | None, str]:
    """(path of the browser, "") or (None, why it cannot be used)."""
    try:
        import websocket  # noqa: F401
    except ImportError:
        return None, "the websocket-client package is not installed (pip install websocket-client)"
    given = os.environ.get("FEMUPDATE_CHROMIUM")
    if given:
        return (given, "") if shutil.which(given) else (None, f"FEMUPDATE_CHROMIUM={given} is not an executable")
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if not exe:
        return None, "no Chromium installed (apt-get install chromium, or set FEMUPDATE_CHROMIUM)"
    return exe, ""


class Browser:
    """One headless Chromium with one page; use as a context manager."""

    def __init__(self, exe: str, width: int = 1280, height: int = 900, timeout: float = 60.0):
        self.exe, self.width, self.height, self.timeout = exe, width, height, timeout
        self.events: list[dict] = []
        self._id = 0

    def __enter__(self) -> "Browser":
        import websocket

        self.profile = tempfile.mkdtemp(prefix="femupdate-chromium-")
        self.proc = subprocess.Popen([self.exe, *FLAGS, f"--user-data-dir={self.profile}", "--remote-debugging-port=0",
                                      f"--window-size={self.width},{self.height}", "about:blank"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        port_file = Path(self.profile) / "DevToolsActivePort"
        t0 = time.monotonic()
        while not (port_file.is_file() and port_file.read_text().strip()):
            if self.proc.poll() is not None or time.monotonic() - t0 > self.timeout:
                self.close()
                raise RuntimeError(f"Chromium did not start (exit code {self.proc.returncode})")
            time.sleep(0.05)
        port = int(port_file.read_text().split()[0])
        pages = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=self.timeout))
        url = next(p["webSocketDebuggerUrl"] for p in pages if p.get("type") == "page")
        self.ws = websocket.create_connection(url, suppress_origin=True, timeout=self.timeout)
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.call(f"{domain}.enable")
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        ws = getattr(self, "ws", None)
        if ws is not None:
            ws.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.profile, ignore_errors=True)

    def _recv(self) -> dict:
        msg = json.loads(self.ws.recv())
        if "method" in msg:
            self.events.append(msg)
        return msg

    def call(self, method: str, **params) -> dict:
        """Send one command and return its result (events that arrive meanwhile are kept)."""
        self._id += 1
        self.ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
        while True:
            msg = self._recv()
            if msg.get("id") == self._id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})

    def load(self, path) -> list[str]:
        """Open a local file and wait for its load event; returns the problems the page reported:
        console errors, uncaught exceptions, failed loads, and any request that is not the file
        itself or a data: URI (a self-contained page makes none)."""
        self.events.clear()
        url = Path(path).resolve().as_uri()
        self.call("Page.navigate", url=url)
        t0 = time.monotonic()
        while not any(e["method"] == "Page.loadEventFired" for e in self.events):
            if time.monotonic() - t0 > self.timeout:
                raise RuntimeError(f"{path}: no load event within {self.timeout} s")
            self._recv()
        self.call("Runtime.evaluate", expression="1")  # let pending console events arrive
        problems = []
        for e in self.events:
            m, p = e["method"], e.get("params", {})
            if m == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                problems.append(f"exception: {d.get('text')} {d.get('exception', {}).get('description', '')}")
            elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                problems.append("console error: " + " ".join(str(a.get("value", a.get("description", "")))
                                                              for a in p.get("args", [])))
            elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                problems.append(f"log error: {p['entry'].get('text')} {p['entry'].get('url', '')}")
            elif m == "Network.requestWillBeSent":
                req = p.get("request", {}).get("url", "")
                if req != url and not req.startswith("data:"):
                    problems.append(f"request to {req}")
            elif m == "Network.loadingFailed":
                problems.append(f"load failed: {p.get('errorText')}")
        return problems

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (JSON-serialisable)."""
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression[:80]}: {r['exceptionDetails'].get('text')}")
        return r["result"].get("value")

    def screenshot(self, path, full_page: bool = False, max_height: int = 8000) -> Path:
        """A PNG of the viewport (or of the whole page, up to ``max_height`` CSS pixels)."""
        params: dict = {"format": "png"}
        if full_page:
            h = min(int(self.evaluate("document.documentElement.scrollHeight")), max_height)
            params.update(captureBeyondViewport=True,
                          clip={"x": 0, "y": 0, "width": self.width, "height": h, "scale": 1})
        data = self.call("Page.captureScreenshot", **params)["data"]
        Path(path).write_bytes(base64.b64decode(data))
        return Path(path)
