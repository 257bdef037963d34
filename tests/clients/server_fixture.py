"""A real gearloop-server for the client tests: the binary named by $GEARLOOP_SERVER_BIN, on a
free loopback port, with a fresh SQLite file in a temporary folder; stopped with SIGTERM.

    with RunningServer() as server:
        print(server.url)          # http://127.0.0.1:PORT
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import socket
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Optional

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "clients" / "examples"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def example_json(name: str) -> dict:
    return json.loads((EXAMPLES / name).read_text())


def write_token_file(folder: str, read_token: str, write_token: str) -> str:
    """A token file of the server ("<role> <sha256-hex> [name]" per line); returns its path."""
    path = os.path.join(folder, "tokens.txt")
    with open(path, "w") as f:
        f.write(f"read {hashlib.sha256(read_token.encode()).hexdigest()} dashboard\n")
        f.write(f"write {hashlib.sha256(write_token.encode()).hexdigest()} cmm-cell-3\n")
    return path


class RunningServer:
    """Starts gearloop-server and waits until /healthz answers (at most `startup_seconds`)."""

    def __init__(self, startup_seconds: float = 30.0, extra_args: Optional[list] = None) -> None:
        self.binary = os.environ.get("GEARLOOP_SERVER_BIN", "")
        if not self.binary or not os.path.exists(self.binary):
            raise RuntimeError("set GEARLOOP_SERVER_BIN to the gearloop-server binary (ctest does)")
        self.startup_seconds = startup_seconds
        self.extra_args = extra_args or []
        self.tmp = tempfile.TemporaryDirectory(prefix="gearloop-clients-")
        self.db = os.path.join(self.tmp.name, "jobs.sqlite")
        self.log_path = os.path.join(self.tmp.name, "server.log")
        self.process: Optional[subprocess.Popen] = None
        self.url = ""

    def __enter__(self) -> "RunningServer":
        # A port found free may be taken before the server binds it: try a few.
        for _ in range(5):
            port = free_port()
            self.url = f"http://127.0.0.1:{port}"
            self._log = open(self.log_path, "ab")
            self.process = subprocess.Popen(
                [self.binary, "--host", "127.0.0.1", "--port", str(port), "--db", self.db] + self.extra_args,
                stdout=self._log, stderr=subprocess.STDOUT)
            if self._wait_healthy():
                return self
            self._stop()
        raise RuntimeError("gearloop-server did not start; log:\n" + self.log())

    def _wait_healthy(self) -> bool:
        deadline = time.monotonic() + self.startup_seconds
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                return False
            try:
                with urllib.request.urlopen(self.url + "/healthz", timeout=2) as r:
                    if r.status == 200:
                        return True
            except OSError:
                pass
            time.sleep(0.1)
        return False

    def _stop(self) -> None:
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if getattr(self, "_log", None):
            self._log.close()

    def log(self) -> str:
        try:
            return Path(self.log_path).read_text(errors="replace")[-4000:]
        except OSError:
            return ""

    def __exit__(self, *exc) -> None:
        self._stop()
        self.tmp.cleanup()
