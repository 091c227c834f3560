"""Calling a compiled kernel again and again with arguments of the same types.

numba's dispatcher finds the numba type of every argument on every call, to
pick the compiled signature. For a kernel taking bundles of some thirty to
fifty arrays and scalars (the procedural plan's and the horse placement's
``NamedTuple`` s), that costs as much as a one-row step itself.
:class:`FixedEntry` calls the dispatcher once, then the compiled entry
point of that signature directly. It lives at the bottom of the package
(it knows nothing of gaits or characters) so both engines use it.
"""

from __future__ import annotations

__all__ = ["FixedEntry"]


class FixedEntry:
    """``kernel(*args)`` for arguments whose types never change.

    The first call goes through numba's dispatcher (compiling or loading the
    kernel) and notes the compiled entry point of the arguments' types; later
    calls go straight to it. The caller's promise: the first call's types
    every call (same dtypes, dimensions, layouts, writeability and bundle
    classes) -- the entry point does not check them. Without a matching
    compiled signature (``NUMBA_DISABLE_JIT``, or arguments the dispatcher
    converted) every call keeps going through the kernel as it is.

    Parameters
    ----------
    kernel : numba dispatcher
        A ``@njit`` function.
    before_first : callable, optional
        Called (without arguments) before the first call only.
    """

    def __init__(self, kernel, before_first=None):
        self.kernel = kernel
        self._entry = None
        self._before_first = before_first

    def __deepcopy__(self, memo):  # shareable: it holds no state of its caller
        return self

    def __call__(self, *args):
        entry = self._entry
        if entry is not None:
            return entry(*args)
        if self._before_first is not None:
            first, self._before_first = self._before_first, None
            first()
        out = self.kernel(*args)
        overloads = getattr(self.kernel, "overloads", None)
        if overloads:
            from numba import typeof

            overload = overloads.get(tuple(typeof(a) for a in args))
            if overload is not None:
                self._entry = overload.entry_point
        return out
