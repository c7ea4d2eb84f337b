"""Run a command as if a person watched it: stdout and stderr on a pseudo-terminal."""

from __future__ import annotations

import fcntl
import os
import pty
import select
import struct
import subprocess
import termios
import time
from pathlib import Path


def run_in_terminal(
    cmd: list[str], *, env: dict[str, str], cwd: Path | None = None, timeout_s: float = 300
) -> tuple[int, str]:
    """Run ``cmd`` with a terminal as its stdout and stderr; return its exit status and output.

    The output is the raw bytes the terminal received (decoded), carriage returns
    included: what tells a redrawn progress bar from plain lines.
    """
    main, child = pty.openpty()
    # a terminal of 100 x 30 (a fresh pty is 0 x 0: nothing fits on a line of it)
    fcntl.ioctl(child, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen(
        cmd, env=env, cwd=cwd, stdin=subprocess.DEVNULL, stdout=child, stderr=child, close_fds=True
    )
    os.close(child)
    chunks: list[bytes] = []
    deadline = time.monotonic() + timeout_s
    try:
        while True:
            if time.monotonic() > deadline:
                proc.kill()
                raise TimeoutError(f"{cmd} ran over {timeout_s} s")
            ready, _, _ = select.select([main], [], [], 0.2)
            if ready:
                try:
                    data = os.read(main, 65536)
                except OSError:  # the child side closed (Linux: EIO)
                    data = b""
                if not data:
                    break
                chunks.append(data)
            elif proc.poll() is not None:
                break
        proc.wait(timeout=30)
    finally:
        os.close(main)
    return proc.returncode, b"".join(chunks).decode("utf-8", "replace")
