"""Writing output files so that a failure never leaves one half-written."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Iterator


def write_text_atomic(path: str | Path, text: str, exclusive: bool = False) -> Path:
    """Write ``text`` to a temporary file beside ``path``, then rename it into place (parents
    created). A failure on the way leaves ``path`` as it was and no temporary file behind. With
    ``exclusive``, only when ``path`` does not exist yet: the complete file is linked into place,
    which fails (``FileExistsError``) when another process got there first."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        (os.link if exclusive else os.replace)(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


@contextlib.contextmanager
def staged_folder(folder: str | Path, publish: Callable[[Path, Path], None]) -> Iterator[Path]:
    """A fresh temporary folder beside ``folder`` to write into. On success it becomes ``folder``
    when that does not exist yet; otherwise ``publish(work, folder)`` moves what it should into
    ``folder`` and the rest is removed. On failure it is removed, and so are the parents created for
    it: ``folder`` is left as it was."""
    folder = Path(folder)
    created = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{folder.name}.partial-", dir=folder.parent))
    umask = os.umask(0)
    os.umask(umask)
    work.chmod(0o777 & ~umask)  # mkdtemp makes it private; the folder it becomes should not be
    try:
        yield work
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        for p in created[1:]:  # parents made for the staging folder, innermost first
            with contextlib.suppress(OSError):
                p.rmdir()
        raise
    if not folder.exists():
        work.rename(folder)
        return
    publish(work, folder)
    shutil.rmtree(work, ignore_errors=True)


def swap_folder(work: Path, out: Path, produced: Callable[[str], bool]) -> None:
    """Replace the folder ``out`` by the staged ``work`` with two renames, so a reader sees the old
    set of outputs or the new one, never a mix. Entries of ``out`` that the job does not produce
    (``produced(name)`` false: a user's own files) are copied into ``work`` first and so carried
    over; the earlier outputs are not. Usable as :func:`staged_folder`'s ``publish``."""
    for p in out.iterdir():
        if not produced(p.name):
            (shutil.copytree if p.is_dir() else shutil.copy2)(p, work / p.name)
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    out.rename(old)
    work.rename(out)
    shutil.rmtree(old, ignore_errors=True)
