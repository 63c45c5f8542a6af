"""Writing output files so that a failure never leaves one half-written: file names made from
labels, temporary names beside an output, staged folders and the lock of a folder being written;
and the schema field types of a file or folder given as an input (:data:`OutputFolder`,
:data:`OutputFile`, :data:`InputFile`), refused before anything runs when it could not be written."""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import secrets
import shutil
import tempfile
from pathlib import Path
from typing import Annotated, Any, Callable, Iterator

from pydantic import AfterValidator, BeforeValidator, Field

from sphere_env.schemas import allowed, shown

#: What a file name made from a label keeps; every other character becomes ``-``.
_UNSAFE = re.compile(r"[^A-Za-z0-9.@_-]")
#: Longest file-name part made from a label (:func:`file_stem`).
MAX_STEM = 64
#: Longest part of an output's name in the temporary names beside it: a name may be as long as the
#: file system allows (255 bytes), so the temporary name cannot hold all of it and more.
_TEMP_STEM = 40


def file_stem(text: str, limit: int = MAX_STEM) -> str:
    """``text`` (a controller label, say) as one safe part of a file name: every character other than
    letters, digits, ``.``, ``-``, ``@`` and ``_`` becomes ``-`` (no path separator, so no way out
    of the folder), and so does a leading ``.`` (no hidden file, never ``.`` or ``..``). A result
    longer than ``limit`` characters is cut and ends in 8 hex digits of a hash of ``text``. Two
    texts can give one stem (``a/b``, ``a-b``): a caller naming several files checks them apart."""
    stem = _UNSAFE.sub("-", text)
    stem = "-" + stem[1:] if stem.startswith(".") else stem or "-"
    if len(stem) > limit:
        stem = f"{stem[: limit - 9]}-{hashlib.sha256(text.encode()).hexdigest()[:8]}"
    return stem


def _temp_prefix(path: Path, kind: str) -> str:
    """The start of a hidden temporary name beside ``path``: ``.<name>.<kind>-``, of bounded length."""
    return f".{file_stem(path.name, _TEMP_STEM)}.{kind}-"


def _umask() -> int:
    """The process's file-mode creation mask (read by setting it and setting it back)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


def write_text_atomic(
    path: str | Path, text: str, exclusive: bool = False, check: Callable[[Path], object] | None = None
) -> Path:
    """Write ``text`` to a temporary file beside ``path``, then rename it into place (parents
    created). A failure on the way leaves ``path`` as it was and no temporary file behind. With
    ``exclusive``, only when ``path`` does not exist yet: the complete file is linked into place,
    which fails (``FileExistsError``) when another process got there first. ``check(temporary
    path)``, when given, runs on the complete file before it goes into place; what it raises
    leaves ``path`` as it was. The file gets the mode of any file the process creates (0666 less
    the umask), not the temporary file's private 0600."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f"{file_stem(path.name, _TEMP_STEM)}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        if check is not None:
            check(Path(tmp))
        (os.link if exclusive else os.replace)(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


#: The lock file of a folder being written: a training's run folder, an evaluation's output folder.
LOCK_FILE = ".lock"


@contextlib.contextmanager
def folder_lock(folder: str | Path, field: str, hint: str, create: bool = True, remove: bool = False) -> Iterator[bool]:
    """Hold ``folder``'s lock while the block runs: an exclusive ``flock`` on ``<folder>/.lock``,
    which then holds this process's pid; the system releases it when the process ends, however it
    ends. When another process holds it: a ValueError naming ``field``, the folder and the holder's
    pid, with ``hint`` (what to do), before anything in the folder is read or changed.

    Without ``create``, no lock is taken on a folder without a lock file, one whose lock file this
    process may not write (a shipped or read-only folder, which no training writes either), or a
    path that is no folder. With ``remove``, a lock file this call created is removed at the end.
    Yields whether the lock is held."""
    import fcntl

    path = Path(folder) / LOCK_FILE
    while True:
        fd, made = _open_lock(path, create)
        if fd is None:
            yield False
            return
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise ValueError(
                f"{field}: {shown(str(folder))} is in use by another process (pid {holder} holds its "
                f"{LOCK_FILE}); {hint}"
            ) from None
        try:
            if os.stat(path).st_ino == os.fstat(fd).st_ino:
                break  # the file still at the path: not one its holder removed before our lock
        except FileNotFoundError:
            pass
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield True
    finally:
        if made and remove:
            with contextlib.suppress(OSError):
                os.unlink(Path(folder) / LOCK_FILE)
        os.close(fd)


def _open_lock(path: Path, create: bool) -> tuple[int | None, bool]:
    """A descriptor of the lock file ``path`` and whether this call created it; without ``create``,
    None for a missing lock file or one this process may not write."""
    while True:
        if create:
            try:
                return os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644), True
            except FileExistsError:
                pass
        try:
            return os.open(path, os.O_RDWR), False
        except FileNotFoundError:
            if not create:
                return None, False
            # removed by its holder in between: create it again
        except OSError as err:
            if create or err.errno not in (errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOTDIR):
                raise
            return None, False


def _holder(fd: int) -> str:
    """The pid in a lock file (its holder writes it right after taking the lock)."""
    import time

    for _ in range(50):
        text = os.pread(fd, 32, 0).decode(errors="replace").strip()
        if text:
            return text if text.isdigit() else "unknown"
        time.sleep(0.01)
    return "unknown"


@contextlib.contextmanager
def staged_folder(folder: str | Path, publish: Callable[[Path, Path], None], lock: str | None = None) -> Iterator[Path]:
    """A fresh temporary folder beside ``folder`` to write into. On success it becomes ``folder``
    when that does not exist yet; otherwise ``publish(work, folder)`` moves what it should into
    ``folder`` and the rest is removed. On failure it is removed, and so are the parents created for
    it: ``folder`` is left as it was.

    With ``lock`` (the field that names ``folder``), ``folder`` is created if need be and locked
    (:func:`folder_lock`) before the staging folder is made, for the whole block: a second writer is
    refused by name, and ``publish`` is always what brings the outputs in."""
    folder = Path(folder)
    created = [p for p in (folder, *folder.parents) if not p.exists()]
    held: contextlib.AbstractContextManager = contextlib.nullcontext()
    if lock is not None:
        folder.mkdir(parents=True, exist_ok=True)
        held = folder_lock(folder, lock, "wait for it to end or write elsewhere", remove=True)
    try:
        with held:
            folder.parent.mkdir(parents=True, exist_ok=True)
            work = Path(tempfile.mkdtemp(prefix=_temp_prefix(folder, "partial"), dir=folder.parent))
            work.chmod(0o777 & ~_umask())  # mkdtemp makes it private; the folder it becomes should not be
            try:
                yield work
            except BaseException:
                shutil.rmtree(work, ignore_errors=True)
                raise
            if not folder.exists():
                work.rename(folder)
                return
            publish(work, folder)
            shutil.rmtree(work, ignore_errors=True)
    except BaseException:
        for p in created if lock is not None else created[1:]:  # made for the block, innermost first
            with contextlib.suppress(OSError):
                p.rmdir()
        raise


def swap_folder(work: Path, out: Path, produced: Callable[[str], bool]) -> None:
    """Replace the folder ``out`` by the staged ``work`` with two renames, so a reader sees the old
    set of outputs or the new one, never a mix. Entries of ``out`` that the job does not produce
    (``produced(name)`` false: a user's own files) are copied into ``work`` first and so carried
    over; the earlier outputs are not. The lock file moves (:func:`folder_lock`: its holder keeps
    it). Usable as :func:`staged_folder`'s ``publish``."""
    for p in out.iterdir():
        if p.name == LOCK_FILE:
            os.rename(p, work / p.name)
        elif not produced(p.name):
            (shutil.copytree if p.is_dir() else shutil.copy2)(p, work / p.name)
    old = out.with_name(f"{_temp_prefix(out, 'old')}{os.getpid()}-{secrets.token_hex(4)}")
    out.rename(old)
    work.rename(out)
    shutil.rmtree(old, ignore_errors=True)


# ---- files and folders as schema fields ---------------------------------------------------------
def _as_path(value: Any) -> Any:
    return Path(value) if isinstance(value, str) and value else value


def writable_location(path: Path) -> None:
    """Refuse ``path`` as an output when it could not be written: a parent is a file, or the
    nearest existing folder above it does not take a new entry (read-only, ``/proc``, no
    permission). The check creates a temporary folder there and removes it at once, so an output
    that cannot be written is refused before anything runs, and nothing is left behind."""
    existing = path
    while not existing.exists():
        if existing.parent == existing:
            break
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        raise ValueError(f"{str(existing)!r} is a file")
    try:
        Path(tempfile.mkdtemp(prefix=".write-probe-", dir=existing)).rmdir()
    except OSError as err:
        raise ValueError(f"cannot write in {str(existing)!r} ({err.strerror or err})") from None


def _output_folder(folder: Path) -> Path:
    writable_location(folder)
    return folder


def _output_file(file: Path) -> Path:
    if file.is_dir():
        raise ValueError("is a folder; give a file name")
    writable_location(file.parent if str(file.parent) else Path("."))
    return file


#: A folder to write into: created when missing; no parent a file, and writable where it will be made.
OutputFolder = Annotated[
    Path,
    BeforeValidator(_as_path),
    AfterValidator(_output_folder),
    Field(
        json_schema_extra=allowed(
            "a folder path (created when missing) in a writable place, none of its parents a file"
        )
    ),
]
#: A file to write: not a folder, in a writable folder (created when missing), no parent a file.
OutputFile = Annotated[
    Path,
    BeforeValidator(_as_path),
    AfterValidator(_output_file),
    Field(json_schema_extra=allowed("a file path in a writable folder, none of its parents a file")),
]
#: A file to read (its contents are checked by the reader).
InputFile = Annotated[Path, BeforeValidator(_as_path), Field(json_schema_extra=allowed("a file path"))]
