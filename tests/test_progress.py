"""Progress: a bar on a terminal, plain lines (no carriage return) in CI and in logs."""

import os
import subprocess
import sys

import pytest

from rwhonet import paths
from rwhonet.progress import LINES, interactive, track
from support.terminal import run_in_terminal

LOOP = """
from rwhonet.progress import track
for _ in track([f"V-{i}" for i in range(25)], desc="simulate", unit="drive", label=str):
    pass
print("done")
"""


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env["PYTHONPATH"] = str(paths.ROOT / "src")
    return {**env, **extra}


def test_a_terminal_gets_a_bar_redrawn_in_place():
    code, out = run_in_terminal([sys.executable, "-c", LOOP], env=_env())
    assert code == 0, out
    assert "\r" in out.replace("\r\n", "\n")  # the bar redraws its line
    assert "simulate:" in out and "/25" in out


@pytest.mark.parametrize("ci", ["true", "1", "TRUE"])
def test_ci_gets_a_few_plain_lines_even_on_a_terminal(ci):
    code, out = run_in_terminal([sys.executable, "-c", LOOP], env=_env(CI=ci))
    assert code == 0, out
    text = out.replace("\r\n", "\n")  # the terminal's own line ending, not a redraw
    assert "\r" not in text
    lines = [ln for ln in text.splitlines() if ln.startswith("simulate:")]
    assert 1 < len(lines) <= LINES
    assert lines[-1].startswith("simulate: 25/25 drives (V-24), ")


def test_captured_output_gets_plain_lines():
    out = subprocess.run([sys.executable, "-c", LOOP], env=_env(), capture_output=True, text=True)
    assert out.returncode == 0 and "\r" not in out.stdout + out.stderr
    assert "simulate: 25/25 drives (V-24)" in out.stdout


def test_plain_lines_without_a_known_length(capsys):
    assert list(track(iter(range(3)), desc="label", unit="segment")) == [0, 1, 2]
    assert capsys.readouterr().out.splitlines()[-1].startswith("label: 3 segments, ")


def test_not_interactive_under_ci(monkeypatch):
    class Tty:
        def isatty(self):
            return True

    monkeypatch.delenv("CI", raising=False)
    assert interactive(Tty())
    monkeypatch.setenv("CI", "true")
    assert not interactive(Tty())
