"""The hydroelastic shells a twin has meshed, kept so that a pressure that recurs costs no re-mesh.

A hydroelastic pressure change replaces the shell's proximity properties, and Drake re-meshes the
compliant shell for that (≈80-90 ms at the shipped 0.05 m resolution). :class:`ShellCache` keeps
the SceneGraph context's resulting GeometryState per shell (modulus, dissipation, mesh
resolution), least recently used first out, and restores it in ≈2 ms (≈1.8 MB each). A snapshot
also holds the ground of its time (pose, μ), which it returns so the twin can bring the ground back
to the current incline and friction; results are bit-identical to a fresh re-mesh.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any, Hashable


class ShellCache:
    """GeometryState snapshots of one SceneGraph context, by shell key, LRU."""

    def __init__(self, sg_context: Any):
        self.sg_context = sg_context
        self._entries: OrderedDict = OrderedDict()
        self._index: int | None = None

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        """Forget every snapshot (the next change of shell re-meshes)."""
        self._entries.clear()

    def restore(self, key: Hashable) -> tuple[float, float] | None:
        """Put the snapshot of ``key`` into the context and return the (ground μ, incline [deg]) it
        holds; ``None`` when there is none."""
        entry = self._entries.get(key)
        if entry is None:
            return None
        snap, mu, incline = entry
        self.sg_context.get_mutable_abstract_parameter(self._state_index()).SetFrom(snap)
        self._entries.move_to_end(key)
        return mu, incline

    def store(self, key: Hashable, ground_mu: float, incline_deg: float, size: int) -> None:
        """Snapshot the context's current GeometryState as ``key``, with the ground μ and incline it
        holds; the least recently used snapshots beyond ``size`` are dropped."""
        self._entries[key] = (
            self.sg_context.get_abstract_parameter(self._state_index()).Clone(),
            ground_mu,
            incline_deg,
        )
        while len(self._entries) > size:
            self._entries.popitem(last=False)

    def _state_index(self) -> int:
        """The index of the GeometryState among the context's abstract parameters (found once)."""
        if self._index is None:
            for i in range(self.sg_context.num_abstract_parameters()):
                try:
                    self.sg_context.get_abstract_parameter(i).get_value()
                except RuntimeError as err:  # C++ type unknown to Python: the message names it
                    if "GeometryState" in str(err):
                        self._index = i
                        break
            if self._index is None:
                raise RuntimeError("SceneGraph context: GeometryState parameter not found")
        return self._index
