"""Ctrl-C for real, for the tests of ``pbrdf batch`` (tests/batch/test_runner.py on a
local cluster, tests/batch/test_slurm.py on Slurm): run ``python -m
mitsuba_pbrdf ARGS`` in a session of its own with this checkout first on
``PYTHONPATH``, wait until its output folder holds a file, and send SIGINT to
its whole process group, as a terminal's Ctrl-C does; or send it after a
given delay from the start (:func:`interrupt_after`, the random-delay tests of
tests/test_interrupts.py) and judge the outcome (:func:`sigint_outcome`)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Mapping, Optional, Sequence

__all__ = ["ROOT", "interrupt_once_output_exists", "interrupt_after", "sigint_outcome"]

#: The checkout (the folder that holds ``mitsuba_pbrdf`` and ``proof``).
ROOT = Path(__file__).resolve().parents[1]


def interrupt_once_output_exists(args: Sequence[str], folder, pattern: str = "*.exr",
                                 env: Optional[Mapping[str, str]] = None,
                                 start_timeout: float = 120.0,
                                 exit_timeout: float = 60.0) -> subprocess.CompletedProcess:
    """Run ``pbrdf ARGS`` (*env*: its environment, default this process's),
    send SIGINT to its process group once *folder* holds a file matching
    *pattern* (or after *start_timeout* s, or at once if it has ended), and
    wait at most *exit_timeout* s for it to exit. Returns its exit status,
    stdout and stderr (text)."""
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    argv = [sys.executable, "-m", "mitsuba_pbrdf", *args]
    # SIGINT's default action in the child, as in a terminal: an ignored
    # SIGINT is inherited through exec (and Python then keeps ignoring it),
    # so a test process that ignores it would make the child deaf to Ctrl-C
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + start_timeout
        while time.monotonic() < deadline and proc.poll() is None:
            if os.path.isdir(folder) and next(Path(folder).glob(pattern), None) is not None:
                break
            time.sleep(0.05)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=exit_timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


def _start(args, env):
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    argv = [sys.executable, "-m", "mitsuba_pbrdf", *args]
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    return argv, proc


def interrupt_after(args: Sequence[str], delay: float, env: Optional[Mapping[str, str]] = None,
                    exit_timeout: float = 120.0) -> subprocess.CompletedProcess:
    """Run ``pbrdf ARGS``, send SIGINT to its process group *delay* seconds
    after the start (unless it has ended), and wait at most *exit_timeout* s.
    Returns its exit status, stdout and stderr (text)."""
    argv, proc = _start(args, env)
    try:
        deadline = time.monotonic() + delay
        while time.monotonic() < deadline and proc.poll() is None:
            time.sleep(min(0.01, max(0.0, deadline - time.monotonic())))
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=exit_timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


def _before_the_hold(err: str) -> bool:
    """Whether a traceback's frames in the package all come before SIGINT can
    be held: none, or the package's import of :mod:`mitsuba_pbrdf.interrupts`
    (the module that holds it) and that module's own imports."""
    frames = re.findall(r'File "([^"]*)", line \d+, in (\S+)(?:\n {4}(\S[^\n]*))?',
                        err.replace(os.sep, "/"))
    return all((path.endswith("mitsuba_pbrdf/__init__.py") and code.startswith("from . import interrupts"))
               or (path.endswith("mitsuba_pbrdf/interrupts.py") and where == "<module>"
                   and code.startswith(("import ", "from ")))
               for path, where, code in frames if "mitsuba_pbrdf/" in path)


def sigint_outcome(result: subprocess.CompletedProcess, command: str) -> str:
    """What a SIGINT did, in words: ``"interrupted"`` (exit 130, the last line
    of stderr ``pbrdf COMMAND: interrupted``, no traceback), ``"finished"``
    (exit 0: it came after the work was done), ``"before python"`` (killed by
    the signal before Python's own handler was installed: nothing had run),
    ``"python startup"`` (a KeyboardInterrupt in Python's start-up, site.py
    or importlib, before the package could hold SIGINT: in its import of
    :mod:`mitsuba_pbrdf.interrupts` at the latest),
    or a description of anything else (a failure of the promise)."""
    err = result.stderr
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip()]
    if result.returncode == -signal.SIGINT and not err.strip():
        return "before python"
    if "KeyboardInterrupt" in err and "pbrdf " not in err and _before_the_hold(err):
        return "python startup"
    if "Traceback" in err or "terminate called" in err:
        return f"exit {result.returncode} with: {err.strip()[-3000:]}"
    if result.returncode == 130 and lines and lines[-1] == f"pbrdf {command}: interrupted":
        return "interrupted"
    if result.returncode == 0:
        return "finished"
    return f"exit {result.returncode}: {err.strip()[-300:]}"
