"""Headless Chromium driven over the DevTools protocol (CDP), for the viewer's browser tests and benchmark.

:class:`Chromium` starts Debian's ``chromium`` (:data:`FLAGS`: headless, no GPU, no network of its own, a new
profile directory), connects to its DevTools endpoint on 127.0.0.1 (``--remote-debugging-port=0``: the port it
picked is read from ``DevToolsActivePort`` in the profile) and opens pages in flattened sessions
(``Target.attachToTarget``), each a :class:`Page`. It is stopped by its own PID (SIGKILL after a deadline).
Uses the ``websockets`` client that viser depends on.
"""

from __future__ import annotations

import base64
import itertools
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from types import TracebackType
from typing import Any

from websockets.sync.client import ClientConnection, connect

__all__ = ['FLAGS', 'chromium_path', 'Chromium', 'Page', 'CdpError', 'INSTALL']

FLAGS = ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
         '--disable-background-networking', '--disable-component-update', '--disable-sync')
"""Chromium's flags besides the profile directory, the DevTools port and the window size."""
INSTALL = 'apt-get install -y chromium'
"""How CI (Debian) installs the browser."""


class CdpError(RuntimeError):
    """The browser answered a command with an error, or did not answer in time."""


def chromium_path() -> str | None:
    """The Chromium executable on PATH (``chromium``, else ``chromium-browser``), or None."""
    return shutil.which('chromium') or shutil.which('chromium-browser')


class Chromium:
    """A headless Chromium process and its DevTools connection.

    Parameters
    ----------
    executable : str
    window : (width, height)
        Pixels of every page.
    timeout : float
        Seconds to wait for the DevTools endpoint.
    """

    def __init__(self, executable: str, *, window: tuple[int, int] = (1280, 800), timeout: float = 30.0) -> None:
        self.profile = Path(tempfile.mkdtemp(prefix='grasp_viewer_chromium_'))
        self.log = self.profile.parent / f'{self.profile.name}.log'
        self._ids = itertools.count(1)
        with self.log.open('wb') as log:
            self.proc = subprocess.Popen(
                [executable, *FLAGS, f'--user-data-dir={self.profile}', '--remote-debugging-address=127.0.0.1',
                 '--remote-debugging-port=0', f'--window-size={window[0]},{window[1]}', 'about:blank'],
                stdout=log, stderr=log, stdin=subprocess.DEVNULL)
        self.window = window
        try:
            self._ws = self._connect(timeout)
        except BaseException:
            self.close()
            raise

    def _connect(self, timeout: float) -> ClientConnection:
        active = self.profile / 'DevToolsActivePort'
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise CdpError(f'chromium exited with code {self.proc.returncode}: {self.log.read_text()[-2000:]}')
            lines = active.read_text().split('\n') if active.is_file() else []
            if len(lines) >= 2 and lines[0].strip().isdigit() and lines[1].strip():
                return connect(f'ws://127.0.0.1:{lines[0].strip()}{lines[1].strip()}', max_size=None,
                               open_timeout=timeout)
            time.sleep(0.05)  # polling a file another process writes: no event to wait on
        raise CdpError(f'no DevTools endpoint within {timeout} s')

    def send(self, method: str, params: dict[str, Any] | None = None, *, session: str | None = None,
             timeout: float = 30.0) -> dict[str, Any]:
        """Send one command and return its result (events that arrive meanwhile are dropped)."""
        command_id = next(self._ids)
        message: dict[str, Any] = {'id': command_id, 'method': method, 'params': params or {}}
        if session is not None:
            message['sessionId'] = session
        self._ws.send(json.dumps(message))
        deadline = time.monotonic() + timeout
        while (remaining := deadline - time.monotonic()) > 0:
            try:
                reply = json.loads(self._ws.recv(timeout=remaining))
            except TimeoutError:
                break
            if reply.get('id') == command_id:
                if 'error' in reply:
                    raise CdpError(f'{method}: {reply["error"]}')
                return dict(reply.get('result', {}))
        raise CdpError(f'{method}: no answer within {timeout} s')

    def open(self, url: str) -> Page:
        """A new page (tab) showing ``url``."""
        target = self.send('Target.createTarget', {'url': 'about:blank'})['targetId']
        session = self.send('Target.attachToTarget', {'targetId': target, 'flatten': True})['sessionId']
        page = Page(self, target, session)
        self.send('Emulation.setDeviceMetricsOverride', {'width': self.window[0], 'height': self.window[1],
                                                          'deviceScaleFactor': 1, 'mobile': False}, session=session)
        self.send('Page.navigate', {'url': url}, session=session)
        return page

    def close(self, timeout: float = 10.0) -> None:
        """Close the browser (Browser.close, then SIGKILL by PID after ``timeout`` s) and delete its profile."""
        ws = getattr(self, '_ws', None)
        if ws is not None and self.proc.poll() is None:
            try:
                ws.send(json.dumps({'id': next(self._ids), 'method': 'Browser.close'}))
            except Exception:  # noqa: BLE001 - the process is killed below if it stays
                pass
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if ws is not None:
            ws.close()
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Chromium:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


class Page:
    """One tab of a :class:`Chromium`."""

    def __init__(self, browser: Chromium, target: str, session: str) -> None:
        self.browser, self.target, self.session = browser, target, session

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (JSON-serialisable values)."""
        result = self.browser.send('Runtime.evaluate', {'expression': expression, 'returnByValue': True},
                                   session=self.session)
        if 'exceptionDetails' in result:
            raise CdpError(f'{expression!r} raised: {result["exceptionDetails"]}')
        return result['result'].get('value')

    def text(self) -> str:
        """The page's visible text (``document.body.innerText``; '' before the body exists)."""
        return str(self.evaluate('document.body ? document.body.innerText : ""') or '')

    def screenshot(self) -> bytes:
        """A PNG of the page as shown."""
        data = self.browser.send('Page.captureScreenshot', {'format': 'png'}, session=self.session)['data']
        return base64.b64decode(data)

    def close(self) -> None:
        """Close the tab."""
        self.browser.send('Target.closeTarget', {'targetId': self.target})
