"""The process tree of a command under test, read from /proc (Linux)."""

from __future__ import annotations

import signal
import time
from pathlib import Path


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (read from /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    out, todo = set(), [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie counts as ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def survivors(pids: set[int], timeout_s: float = 30.0) -> list[int]:
    """The processes of ``pids`` still running once all ended or ``timeout_s`` passed (a process
    ends a moment after its parent saw it stop: polled, not slept for)."""
    deadline = time.monotonic() + timeout_s
    while (running := [p for p in pids if alive(p)]) and time.monotonic() < deadline:
        time.sleep(0.05)
    return running


def session(sid: int) -> dict[int, int]:
    """pid -> parent pid of every live process of session ``sid`` (an orphan keeps its session)."""
    out = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            out[int(stat.parent.name)] = int(fields[1])
    return out


def as_from_a_terminal() -> None:
    """In a child before exec: SIGINT and SIGTERM with their default action and unblocked, as a
    command started from a terminal has them. A process inherits an ignored or blocked signal from
    its parent, and a test worker's state is not a terminal's (a Python started with SIGINT
    ignored never raises KeyboardInterrupt)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
