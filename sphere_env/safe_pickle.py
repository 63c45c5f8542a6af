"""Pickles read as data: the only pickles the project reads (a stable-baselines3 ``model.zip``'s
cloudpickled entries, an older run folder's ``vecnormalize.pkl``) go through :func:`loads` or
:func:`class_reference`, which never run code from the file.

* :func:`loads` rebuilds only the objects of :data:`DATA_GLOBALS`: numpy arrays, dtypes, scalars and
  random generators, ``collections.deque``/``OrderedDict``, gymnasium spaces and stable-baselines3's
  normalization statistics (``RunningMeanStd``, ``VecNormalize`` without its env). The opcodes are
  read first, without unpickling: any other global (a function, ``os.system``, a pickled code
  object), a call of anything but a constructor of :data:`CALLABLE_GLOBALS` (a space or statistics
  object is created from its state, never by calling its constructor, whose shape argument could
  ask for gigabytes), is refused by name before anything is called.
* :func:`class_reference` reads a pickle that is one reference to a class (how cloudpickle stores an
  importable class, such as a model's policy class) without unpickling it: the stream's opcodes are
  read, the class is imported only from :data:`CLASS_MODULES` and must derive from the given bases.

A refusal is an :class:`UnsafePickleError` (a ``ValueError``) naming where the pickle came from.
"""

from __future__ import annotations

import importlib
import io
import pickle
import pickletools
from typing import Any

from sphere_env.schemas import shown

#: The largest pickle read [bytes] (normalization statistics and a model's entries are kilobytes).
MAX_BYTES = 64 * 1024 * 1024

_SPACES = [
    (f"gymnasium.spaces.{module}", name)
    for module, name in (
        ("box", "Box"),
        ("discrete", "Discrete"),
        ("multi_discrete", "MultiDiscrete"),
        ("multi_binary", "MultiBinary"),
        ("dict", "Dict"),
        ("tuple", "Tuple"),
    )
]
#: Globals a data pickle may call (REDUCE): each builds a value from the file's bytes and nothing else.
CALLABLE_GLOBALS = frozenset(
    [
        (core, name)
        for core in ("numpy.core.multiarray", "numpy._core.multiarray", "numpy.core.numeric", "numpy._core.numeric")
        for name in ("_reconstruct", "scalar", "_frombuffer")
    ]
    + [
        ("numpy", "dtype"),
        ("numpy.random._pickle", "__generator_ctor"),
        ("numpy.random._pickle", "__bit_generator_ctor"),
        ("numpy.random._pickle", "__randomstate_ctor"),
        ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
        ("collections", "deque"),
        ("collections", "OrderedDict"),
    ]
)
#: Classes a data pickle may create without calling their constructor (NEWOBJ, then its state).
CREATED_GLOBALS = frozenset(
    _SPACES
    + [
        ("stable_baselines3.common.running_mean_std", "RunningMeanStd"),
        ("stable_baselines3.common.vec_env.vec_normalize", "VecNormalize"),
        ("collections", "OrderedDict"),
    ]
)
#: Globals that may only appear as arguments (a numpy array's class, a random generator's).
ARGUMENT_GLOBALS = frozenset(
    [
        ("numpy", "ndarray"),
        ("numpy.random._pcg64", "PCG64"),
        ("numpy.random._mt19937", "MT19937"),
        ("numpy.random._philox", "Philox"),
        ("numpy.random._sfc64", "SFC64"),
        ("numpy.random.bit_generator", "SeedSequence"),
    ]
)
#: Every global a data pickle may name: nothing among them runs code or touches files.
DATA_GLOBALS = CALLABLE_GLOBALS | CREATED_GLOBALS | ARGUMENT_GLOBALS
#: Modules a class reference may be imported from (installed code, never the file's).
CLASS_MODULES = ("stable_baselines3.", "sb3_contrib.", "sphere_env.")
_STRING_OPS = frozenset({"SHORT_BINUNICODE", "BINUNICODE", "BINUNICODE8", "UNICODE"})
_MEMO_PUT = frozenset({"MEMOIZE", "PUT", "BINPUT", "LONG_BINPUT"})
_MEMO_GET = frozenset({"GET", "BINGET", "LONG_BINGET"})
#: Opcodes never in a data pickle: protocol 0/1 instantiation, persistent ids, the extension registry.
_REFUSED_OPS = frozenset({"INST", "OBJ", "PERSID", "BINPERSID", "EXT1", "EXT2", "EXT4"})
#: The opcodes of a pickle that is one class reference and nothing else.
_REFERENCE_OPS = frozenset({"PROTO", "FRAME", "STOP", "GLOBAL", "STACK_GLOBAL"} | _STRING_OPS | _MEMO_PUT | _MEMO_GET)


_MARK = object()  # a MARK on the simulated stack


class UnsafePickleError(ValueError):
    """A pickle refused: it names or calls something other than data, or is too large."""


def _name(item: Any) -> str:
    return shown(".".join(item[1:]) if isinstance(item, tuple) else "a value built by the pickle")


def _walk(
    data: bytes, where: str, called: frozenset = CALLABLE_GLOBALS, created: frozenset = CREATED_GLOBALS
) -> list[tuple[str, str]]:
    """The globals a pickle names, after checking from its opcodes alone (nothing is unpickled)
    that it calls only ``called`` and creates only ``created``."""
    stack: list[Any] = []  # ("G", module, name) for a global, the text for a string, None for other values
    memo: dict[Any, Any] = {}
    names: list[tuple[str, str]] = []
    for op, arg, _ in pickletools.genops(data):
        if op.name in _REFUSED_OPS:
            raise UnsafePickleError(f"{where}: the pickle uses {op.name}, which data pickles never do; refused")
        if op.name in _MEMO_PUT:
            memo[len(memo) if op.name == "MEMOIZE" else arg] = stack[-1]
            continue
        if op.name in _MEMO_GET:
            stack.append(memo[arg])
            continue
        if op.name == "DUP":
            stack.append(stack[-1])
            continue
        if op.name in ("REDUCE", "NEWOBJ", "NEWOBJ_EX"):
            target = stack[-3 if op.name == "NEWOBJ_EX" else -2]
            allowed = called if op.name == "REDUCE" else created
            if not (isinstance(target, tuple) and target[1:] in allowed):
                raise UnsafePickleError(
                    f"{where}: the pickle calls {_name(target)}, which is not a constructor of plain data "
                    "(numpy arrays, gymnasium spaces, normalization statistics); refused without running it"
                )
        pushed: Any = None
        if op.name == "GLOBAL":
            pushed = ("G", *arg.split(" ", 1))
        elif op.name == "STACK_GLOBAL":
            pushed = ("G", stack[-2], stack[-1])
        elif op.name in _STRING_OPS:
            pushed = arg
        if isinstance(pushed, tuple):
            if not all(isinstance(part, str) for part in pushed):
                raise UnsafePickleError(f"{where}: a global named by computed values; refused")
            names.append(pushed[1:])
        before = [s.name for s in op.stack_before]
        if "mark" in before:
            while stack.pop() is not _MARK:
                pass
            before = before[: before.index("mark")]
        del stack[len(stack) - len(before) :]
        after = [_MARK if s.name == "mark" else pushed for s in op.stack_after]
        stack.extend(after)
    return names


class _DataUnpickler(pickle.Unpickler):
    def __init__(self, data: bytes, where: str, names: frozenset):
        super().__init__(io.BytesIO(data))
        self.where, self.names = where, names

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in self.names:  # the walk has refused it already; kept as a second guard
            raise UnsafePickleError(f"{self.where}: the pickle names {shown(f'{module}.{name}')}; refused")
        return super().find_class(module, name)


def _refuse_names(names: list[tuple[str, str]], where: str, allowed: frozenset) -> None:
    for module, name in names:
        if (module, name) not in allowed:
            raise UnsafePickleError(
                f"{where}: the pickle names {shown(f'{module}.{name}')}, which is not plain data "
                "(numpy arrays, gymnasium spaces, normalization statistics); refused without running it"
            )


def loads(
    data: bytes,
    where: str,
    called: tuple[tuple[str, str], ...] = (),
    created: tuple[tuple[str, str], ...] = (),
    max_bytes: int = MAX_BYTES,
) -> Any:
    """The object a data pickle holds (:data:`DATA_GLOBALS` only, and the caller's own ``called``
    constructors and ``created`` classes, such as a replay buffer's), at most ``max_bytes`` long.

    :raises UnsafePickleError: naming ``where`` and the refused global or call.
    :raises ValueError: ``where``: the pickle is malformed.
    """
    if len(data) > max_bytes:
        raise UnsafePickleError(f"{where}: {len(data)} bytes of pickle; at most {max_bytes} are read")
    calls, creates = CALLABLE_GLOBALS | set(called), CREATED_GLOBALS | set(created)
    allowed = DATA_GLOBALS | calls | creates
    try:
        _refuse_names(_walk(data, where, calls, creates), where, allowed)
        return _DataUnpickler(data, where, allowed).load()
    except UnsafePickleError:
        raise
    except Exception as err:  # noqa: BLE001 - truncated or malformed: not readable
        raise ValueError(f"{where}: not a readable pickle ({type(err).__name__}: {shown(str(err))})") from None


def class_reference(data: bytes, where: str, bases: tuple[type, ...]) -> type:
    """The class a pickle refers to when it is one reference to a class of :data:`CLASS_MODULES`
    deriving from ``bases``, read from the opcodes without unpickling.

    :raises UnsafePickleError: naming ``where``: anything else (a class pickled by value, a call).
    """
    if len(data) > MAX_BYTES:
        raise UnsafePickleError(f"{where}: {len(data)} bytes of pickle; at most {MAX_BYTES} are read")
    try:
        ops = {op.name for op, _, _ in pickletools.genops(data)}
        names = _walk(data, where)
    except UnsafePickleError:
        raise
    except Exception as err:  # noqa: BLE001 - a malformed stream
        raise ValueError(f"{where}: not a readable pickle ({type(err).__name__}: {shown(str(err))})") from None
    if not ops <= _REFERENCE_OPS or len(names) != 1:
        raise UnsafePickleError(f"{where}: not one reference to an importable class (a class pickled with its code?)")
    ((module, name),) = names
    if not module.startswith(CLASS_MODULES) or not name.isidentifier():
        raise UnsafePickleError(
            f"{where}: the class {shown(f'{module}.{name}')} is not from {list(CLASS_MODULES)}; refused"
        )
    try:
        cls = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as err:
        raise ValueError(f"{where}: the class {shown(f'{module}.{name}')} cannot be imported: {err}") from None
    if not (isinstance(cls, type) and issubclass(cls, bases)):
        raise UnsafePickleError(
            f"{where}: {shown(f'{module}.{name}')} is not a subclass of {[b.__name__ for b in bases]}; refused"
        )
    return cls
