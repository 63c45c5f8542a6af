"""MP4 videos of episodes through :class:`gymnasium.wrappers.RecordVideo` (needs the ``video`` extra,
moviepy), written atomically into a video folder.

One file per episode, named by controller, shell model, pressure and seed
(``ppo_injected_8.5kPa_s0.mp4``); a frame at the reset and one per step, at the env's control
frequency (``metadata["render_fps"]``). Videos are first written into a staging folder beside the
video folder and moved into place only when every episode has finished: a failure leaves the
folder as it was.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from sphere_env.files import file_stem, staged_folder


def check_video_support() -> None:
    """Refuse to record videos without moviepy, before any episode runs."""
    try:
        import moviepy  # noqa: F401
    except ImportError:
        raise ValueError('video: writing MP4s needs moviepy; install it with pip install "sphere_env[video]"') from None


def video_name(controller: str, shell_model: str, pressure_kpa: float, seed: int, extra: str = "") -> str:
    """File stem of an episode's video: ``<controller>_<shell model>[_<extra>]_<pressure>kPa_s<seed>``,
    each part a :func:`sphere_env.files.file_stem` (characters other than letters, digits, ``.``,
    ``-``, ``@`` and ``_`` become ``-``; a long label is cut)."""
    parts = [controller, shell_model, *([extra] if extra else []), f"{pressure_kpa:g}kPa", f"s{seed}"]
    return "_".join(file_stem(str(p)) for p in parts)


def record_episode(env: Any, folder: str | Path, name: str, run: Callable[[Any], Any]) -> Any:
    """Run one episode, ``run(wrapped_env)``, with ``env`` (``render_mode="rgb_array"``) wrapped in
    ``RecordVideo`` and write ``folder/<name>.mp4``. Returns what ``run`` returns. ``env`` is not
    closed (a worker reuses it); a failing episode writes no file."""
    from gymnasium.wrappers import RecordVideo

    folder = Path(folder)
    scratch = folder / f".{name}.frames"  # RecordVideo's own folder (it warns when reusing one)
    rec = RecordVideo(env, str(scratch), episode_trigger=lambda _: True, name_prefix=name, disable_logger=True)
    try:
        result = run(rec)
        if not rec.recording:
            raise RuntimeError(f"video: no frames were recorded for {name!r} (was the env reset?)")
        rec.stop_recording()  # writes <scratch>/<name>-episode-<k>.mp4
        (written,) = scratch.glob("*.mp4")
        os.replace(written, folder / f"{name}.mp4")
    finally:
        rec.recorded_frames = []  # a failed episode: drop its frames (no "unable to save" warning)
        rec.recording = False
        shutil.rmtree(scratch, ignore_errors=True)
    return result


def _move_videos(work: Path, folder: Path) -> None:
    for p in work.glob("*.mp4"):
        os.replace(p, folder / p.name)


@contextlib.contextmanager
def staged_videos(folder: Path | None) -> Iterator[Path | None]:
    """A fresh staging folder beside ``folder`` (None: no videos, yields None). On success its MP4s
    move into ``folder`` (same names replaced, other files kept); on failure it is removed, and so
    are the parents created for it."""
    if folder is None:
        yield None
        return
    with staged_folder(folder, _move_videos) as work:
        yield work
