"""Fluents: values that can be waited on (CRAM's value fluents, nets and pulse fluents).

- :class:`Fluent` holds a value and pulses when it changes; ``wait_for`` blocks on it.
- Operators (``< <= > >= + - * /``) and :func:`fl_and`, :func:`fl_or`, :func:`fl_not`,
  :func:`fl_eq`, :func:`fl_funcall` build *nets*: fluents computed from other fluents.
- :func:`pulsed` turns pulses into values that are consumed on read.
- :func:`wait_for` and :func:`whenever` wait on any of them.

All of this is meant to run on the event loop's thread. Setting a fluent from another
thread (a ROS callback, say) is routed through ``loop.call_soon_threadsafe`` to the loop
the fluent belongs to.
"""

from __future__ import annotations

import asyncio
import operator
import weakref
from collections.abc import AsyncIterator, Callable, Sequence
from threading import get_ident
from typing import Any, Generic, Literal, TypeVar, overload

from ._scheduling import CURRENT_TASK, block_until
from ._timeline import current_time

__all__ = [
    "Fluent",
    "fl_and",
    "fl_eq",
    "fl_funcall",
    "fl_not",
    "fl_or",
    "fl_value_changed",
    "pulsed",
    "wait_for",
    "whenever",
]

T = TypeVar("T")

HandleMissed = Literal["once", "always", "never"]
_HANDLE_MISSED = ("once", "always", "never")


def _default_test(old: Any, new: Any) -> bool:
    """Equal values do not pulse. Non-boolean comparisons (numpy arrays) count as a change."""
    if old is new:
        return True
    try:
        same = old == new
    except Exception:
        return False
    return same if isinstance(same, bool) else False


class Fluent(Generic[T]):
    """A value that pulses when it changes.

    Setting ``value`` to something that ``test(old, new)`` calls equal does nothing; any other
    assignment stores the value and pulses: the pulse count grows, every waiter wakes and
    each ``on_update`` callback is called synchronously with the new value, in registration
    order. ``pulse()`` pulses without a change. Creating a fluent does not pulse it.

    Never overloads ``__eq__``, ``__hash__`` or ``__bool__``: fluents hash by identity and
    ``if fluent:`` is always true; test ``fluent.value`` (or use :func:`wait_for`). The
    comparison and arithmetic operators return derived fluents (nets), so ``f < 3`` is a
    fluent, not a bool, and ``sorted()`` of fluents is meaningless.

    **Threads.** A fluent remembers the event loop it was created in or last waited on.
    Setting ``value`` or calling ``pulse()`` from another thread schedules the update on
    that loop with ``call_soon_threadsafe`` (the new value is visible once the loop has run
    it); if that loop is closed, the update is applied directly. A fluent that no loop has
    seen yet is updated in the calling thread.
    """

    __slots__ = (
        "__weakref__",
        "_callbacks",
        "_loop",
        "_loop_thread",
        "_test",
        "_value",
        "_waiters",
        "name",
        "pulse_count",
    )

    #: Whether reading the value has no side effect, so a net over it may cache.
    _cacheable = True

    def __init__(
        self,
        value: T = None,  # type: ignore[assignment]
        name: str | None = None,
        *,
        test: Callable[[Any, Any], bool] | None = None,
    ) -> None:
        self._value: T = value
        self.name: str = name if name is not None else "fluent"
        self._test: Callable[[Any, Any], bool] = test if test is not None else _default_test
        # Invariant: callbacks run in registration order; None when there are none (cheap
        # status fluents on 100k tasks).
        self._callbacks: dict[object, Callable[[T], Any]] | None = None
        # Invariant: every future here is pending or was resolved by the last pulse; waiters
        # remove their own future when they stop waiting.
        self._waiters: list[asyncio.Future[None]] | None = None
        self.pulse_count: int = 0
        # The loop this fluent belongs to and the id of the thread running it (None until
        # the fluent is created in, or waited on from, a running loop).
        loop = asyncio._get_running_loop()
        self._loop: asyncio.AbstractEventLoop | None = loop
        self._loop_thread: int | None = None if loop is None else get_ident()

    @property
    def value(self) -> T:
        return self._value

    @value.setter
    def value(self, new: T) -> None:
        tid = self._loop_thread
        if tid is not None and tid != get_ident() and self._call_in_loop(self._set, new):
            return
        if self._test(self._value, new):
            return
        self._value = new
        self._pulse()

    def set_threadsafe(self, value: T) -> None:
        """Set the value from any thread (the explicit spelling of ``fluent.value = value``).

        From a thread other than the fluent's loop, the update is scheduled on the loop and
        applied there, in order with other updates from the same thread.
        """
        self.value = value

    def _set(self, new: T) -> None:
        if self._test(self._value, new):
            return
        self._value = new
        self._pulse()

    def peek_value(self) -> T:
        """Read without consuming (matters for pulse fluents only)."""
        return self._value

    def pulse(self) -> None:
        """Wake every waiter and call the callbacks, without changing the value."""
        tid = self._loop_thread
        if tid is not None and tid != get_ident() and self._call_in_loop(self._pulse):
            return
        self._pulse()

    def _pulse(self) -> None:
        self.pulse_count += 1
        task = CURRENT_TASK.get()
        if task is not None and task._run is not None:
            hooks = task._run.instruments.fluent_changed
            if hooks:
                value = self.peek_value()
                for hook in hooks:
                    hook(self, value)
        waiters = self._waiters
        if waiters:
            self._waiters = None
            for fut in waiters:
                if not fut.done():
                    fut.set_result(None)
        callbacks = self._callbacks
        if callbacks:
            value = self._value
            for cb in list(callbacks.values()):
                cb(value)

    def _call_in_loop(self, fn: Callable[..., Any], *args: Any) -> bool:
        """Schedule ``fn(*args)`` on this fluent's loop; ``False`` if the loop is gone."""
        loop = self._loop
        if loop is None:
            return False
        try:
            loop.call_soon_threadsafe(fn, *args)
        except RuntimeError:  # the loop is closed: nobody can be waiting on it any more
            self._loop = None
            self._loop_thread = None
            return False
        return True

    def on_update(self, callback: Callable[[T], Any], key: object = None) -> Callable[[], None]:
        """Call ``callback(new_value)`` synchronously on every pulse.

        Returns a function that removes the callback. ``key`` names it (a duplicate key is
        an error, as in CRAM); by default the callback itself is the key. An exception in a
        callback propagates to whoever set the value or pulsed; later callbacks then do not
        run for that pulse.
        """
        if self._callbacks is None:
            self._callbacks = {}
        k = callback if key is None else key
        if k in self._callbacks:
            raise ValueError(
                f"fluent {self.name!r} already has an update callback {k!r}; remove it "
                "first (remove_update_callback) or register under another key"
            )
        self._callbacks[k] = callback

        def remove() -> None:
            if self._callbacks is not None:
                self._callbacks.pop(k, None)

        return remove

    def remove_update_callback(self, key: object) -> bool:
        """Remove the callback registered under ``key``; ``False`` if there was none."""
        callbacks = self._callbacks
        if callbacks is None or key not in callbacks:
            return False
        del callbacks[key]
        return True

    def _waiter(self) -> asyncio.Future[None]:
        """A fresh future resolved by the next pulse (register before you block).

        Binds the fluent to the running loop (see the class docstring on threads).
        """
        loop = asyncio.get_running_loop()
        if loop is not self._loop:
            self._loop = loop
            self._loop_thread = get_ident()
        fut: asyncio.Future[None] = loop.create_future()
        if self._waiters is None:
            self._waiters = [fut]
        else:
            self._waiters.append(fut)
        return fut

    def _remove_waiter(self, fut: asyncio.Future[None]) -> None:
        waiters = self._waiters
        if waiters:
            try:
                waiters.remove(fut)
            except ValueError:
                pass

    def __repr__(self) -> str:
        try:
            shown = repr(self.peek_value())
        except Exception as exc:  # a net whose function fails must still print
            shown = f"<{type(exc).__name__}>"
        return f"<{type(self).__name__} {self.name}={shown}>"

    # Operators: derived fluents. Never __eq__/__ne__/__hash__/__bool__ (see class docstring).

    def __lt__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.lt, (self, other), "<")

    def __le__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.le, (self, other), "<=")

    def __gt__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.gt, (self, other), ">")

    def __ge__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.ge, (self, other), ">=")

    def __add__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.add, (self, other), "+")

    def __radd__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.add, (other, self), "+")

    def __sub__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.sub, (self, other), "-")

    def __rsub__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.sub, (other, self), "-")

    def __mul__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.mul, (self, other), "*")

    def __rmul__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.mul, (other, self), "*")

    def __truediv__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.truediv, (self, other), "/")

    def __rtruediv__(self, other: Any) -> Fluent[Any]:
        return _op_net(operator.truediv, (other, self), "/")


# --------------------------------------------------------------------------- nets

Reader = Callable[[Any], Any]


def _read_value(x: Any) -> Any:
    return x.value if isinstance(x, Fluent) else x


def _read_peek(x: Any) -> Any:
    return x.peek_value() if isinstance(x, Fluent) else x


class _InputCallback:
    """The ``on_update`` callback an input holds for a net or pulse fluent.

    Holds both ends weakly: the input does not keep the net alive, and once the net is
    collected the callback removes itself on the input's next pulse (it is its own key).
    """

    __slots__ = ("input_ref", "target_ref")

    def __init__(self, source: Fluent[Any], target: _Derived[Any]) -> None:
        self.input_ref = weakref.ref(source)
        self.target_ref = weakref.ref(target)

    def __call__(self, _value: Any) -> None:
        target = self.target_ref()
        if target is None:
            source = self.input_ref()
            if source is not None:
                source.remove_update_callback(self)
            return
        target._input_pulsed()


def _refuse_set(fluent: Fluent[Any]) -> None:
    raise AttributeError(
        f"cannot set the value of {fluent.name!r}: it is computed from its inputs; "
        "set one of the input fluents instead"
    )


class _Derived(Fluent[T]):
    """A fluent whose value comes from its inputs; it cannot be set."""

    __slots__ = ("_inputs",)

    def _listen(self, inputs: Sequence[Any]) -> None:
        seen: dict[int, Fluent[Any]] = {}
        for x in inputs:
            if isinstance(x, Fluent):
                seen.setdefault(id(x), x)
        # The net keeps its inputs alive; the inputs hold the net only weakly.
        self._inputs = tuple(seen.values())
        for source in self._inputs:
            cb = _InputCallback(source, self)
            source.on_update(cb, cb)

    @property
    def value(self) -> T:
        return self._value

    @value.setter
    def value(self, new: T) -> None:
        _refuse_set(self)

    def _input_pulsed(self) -> None:
        tid = self._loop_thread
        if tid is not None and tid != get_ident() and self._call_in_loop(self._update):
            return
        self._update()

    def _update(self) -> None:
        """Recompute after an input pulsed; every kind of derived fluent defines it."""
        raise NotImplementedError(
            f"{type(self).__name__} derives from _Derived but does not define _update()"
        )


class _CacheableNet(_Derived[T]):
    """A net over cacheable inputs: computed once per input pulse, pulses only on a change."""

    __slots__ = ("_compute",)

    def __init__(self, compute: Callable[[Reader], T], inputs: Sequence[Any], name: str) -> None:
        super().__init__(compute(_read_value), name)
        self._compute = compute
        self._listen(inputs)

    def _update(self) -> None:
        new = self._compute(_read_value)
        if self._test(self._value, new):
            return
        self._value = new
        self._pulse()


class _Net(_Derived[T]):
    """A net with a consuming input (a pulse fluent): recomputed on every read.

    Reading ``value`` reads the inputs' values (consuming pulse fluents, in argument order,
    short-circuiting for ``fl_and``/``fl_or``); ``peek_value`` consumes nothing. It pulses on
    every pulse of any input.
    """

    __slots__ = ("_compute",)
    _cacheable = False

    def __init__(self, compute: Callable[[Reader], T], inputs: Sequence[Any], name: str) -> None:
        super().__init__(None, name)  # type: ignore[arg-type]
        self._compute = compute
        self._listen(inputs)

    @property
    def value(self) -> T:
        return self._compute(_read_value)

    @value.setter
    def value(self, new: T) -> None:
        _refuse_set(self)

    def peek_value(self) -> T:
        return self._compute(_read_peek)

    def _update(self) -> None:
        self._pulse()


def _has_fluent(args: Sequence[Any]) -> bool:
    return any(isinstance(a, Fluent) for a in args)


def _name_of(x: Any) -> str:
    return x.name if isinstance(x, Fluent) else repr(x)


def _make_net(compute: Callable[[Reader], Any], args: Sequence[Any], name: str) -> Fluent[Any]:
    if all(x._cacheable for x in args if isinstance(x, Fluent)):
        return _CacheableNet(compute, args, name)
    return _Net(compute, args, name)


def _net(fn: Callable[..., Any], args: tuple[Any, ...], symbol: str) -> Any:
    """``fn`` applied to the values of ``args``: a net if any is a fluent, else the result."""
    if not _has_fluent(args):
        return fn(*args)
    return _op_net(fn, args, symbol)


def _op_net(fn: Callable[..., Any], args: tuple[Any, ...], symbol: str) -> Fluent[Any]:
    name = f"({' '.join([symbol, *map(_name_of, args)])})"
    return _make_net(lambda read: fn(*[read(a) for a in args]), args, name)


def fl_funcall(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*values)`` as a fluent: recomputed whenever an argument fluent pulses.

    Like CRAM's operators, only direct arguments count as inputs (a list holding fluents
    does not); with no fluent argument, returns ``fn(*args)`` at once. A net over value
    fluents (or other such nets) is cacheable: it recomputes on each input pulse and pulses
    only when the result changed. A net over a pulse fluent recomputes on every read and
    pulses on every input pulse. An exception from ``fn`` propagates to the reader, or to
    whoever changed an input of a cacheable net.
    """
    return _net(fn, args, getattr(fn, "__name__", "funcall"))


def fl_eq(a: Any, b: Any) -> Any:
    """``a == b`` over fluent values (a plain bool if neither is a fluent).

    Deliberate difference: CRAM's ``fl-eq`` tests identity (``eq``); Python code means ``==``.
    Use ``fl_funcall(operator.is_, a, b)`` for identity. ``Fluent.__eq__`` is never
    overloaded, so this is the only way to build an equality net.
    """
    return _net(operator.eq, (a, b), "==")


def fl_not(x: Any) -> Any:
    """``not value`` of ``x`` as a fluent (a plain bool if ``x`` is not a fluent)."""
    return _net(operator.not_, (x,), "not")


def _and(read: Reader, args: Sequence[Any]) -> Any:
    result: Any = True
    for a in args:
        result = read(a)
        if not result:
            return result
    return result


def _or(read: Reader, args: Sequence[Any]) -> Any:
    result: Any = None
    for a in args:
        result = read(a)
        if result:
            return result
    return result


def fl_and(*args: Any) -> Any:
    """The values of ``args`` combined with ``and``, as a fluent if any argument is one.

    Reads short-circuit left to right (so a pulse fluent after a false argument is not
    consumed) and the result is the last value if all are truthy, else the first falsy one.
    ``fl_and()`` is ``True``.
    """
    if not _has_fluent(args):
        return _and(_read_value, args)
    return _make_net(lambda read: _and(read, args), args, f"(and {' '.join(map(_name_of, args))})")


def fl_or(*args: Any) -> Any:
    """The values of ``args`` combined with ``or``, as a fluent if any argument is one.

    Reads short-circuit left to right; the result is the first truthy value, else the last
    value. ``fl_or()`` is ``None`` (CRAM's ``NIL``).
    """
    if not _has_fluent(args):
        return _or(_read_value, args)
    return _make_net(lambda read: _or(read, args), args, f"(or {' '.join(map(_name_of, args))})")


class _ValueChanged(_Derived[bool]):
    """True once per change of ``key(value)`` of the source; each read updates the memory."""

    __slots__ = ("_key", "_old", "_source", "_vtest")
    _cacheable = False

    def __init__(
        self,
        source: Fluent[Any],
        test: Callable[[Any, Any], bool],
        key: Callable[[Any], Any],
    ) -> None:
        super().__init__(False, f"(value-changed {source.name})")
        self._source = source
        self._vtest = test
        self._key = key
        self._old = key(source.peek_value())
        self._listen((source,))

    @property
    def value(self) -> bool:
        new = self._key(self._source.value)
        changed = not self._vtest(self._old, new)
        self._old = new
        return changed

    @value.setter
    def value(self, new: bool) -> None:
        _refuse_set(self)

    def peek_value(self) -> bool:
        return not self._vtest(self._old, self._key(self._source.peek_value()))

    def _update(self) -> None:
        self._pulse()


def fl_value_changed(
    fluent: Fluent[Any],
    *,
    test: Callable[[Any, Any], bool] | None = None,
    key: Callable[[Any], Any] | None = None,
) -> Fluent[bool]:
    """A fluent that reads ``True`` once per change of ``key(fluent.value)``.

    Each read compares with the keyed value seen at the previous read (or at creation) and
    remembers the new one, so reading consumes. ``test(old, new)`` says "unchanged" (default:
    equality as in :class:`Fluent`). Pulses on every pulse of ``fluent``. Deliberate
    difference: CRAM remembers the raw value instead of the keyed one (a bug); we remember
    the keyed value.
    """
    if not isinstance(fluent, Fluent):
        raise TypeError(f"fl_value_changed needs a Fluent, got {fluent!r}")
    return _ValueChanged(
        fluent,
        test if test is not None else _default_test,
        key if key is not None else _identity,
    )


def _identity(x: Any) -> Any:
    return x


# --------------------------------------------------------------------------- pulse fluents


class _PulseFluent(_Derived[bool]):
    """True after the source pulsed; reading ``value`` consumes (see :func:`pulsed`)."""

    __slots__ = ("_always", "_processed", "_source")
    _cacheable = False

    def __init__(self, source: Fluent[Any], handle_missed: HandleMissed) -> None:
        super().__init__(False, f"(pulsed {source.name} {handle_missed})")
        self._source = source
        self._always = handle_missed == "always"
        self._processed = source.pulse_count if handle_missed == "never" else 0
        self._listen((source,))

    @property
    def value(self) -> bool:
        count = self._source.pulse_count
        if self._processed >= count:
            return False
        if self._always:
            self._processed += 1
        else:
            self._processed = count
        return True

    @value.setter
    def value(self, new: bool) -> None:
        _refuse_set(self)

    def peek_value(self) -> bool:
        return self._processed < self._source.pulse_count

    def _update(self) -> None:
        self._pulse()


def pulsed(fluent: Fluent[Any], handle_missed: HandleMissed = "once") -> Fluent[bool]:
    """A pulse fluent: ``True`` after ``fluent`` pulsed; each read of ``value`` consumes.

    ``handle_missed`` says how pulses not yet read count:

    - ``"once"`` (default): true if ``fluent`` pulsed since the last read, or ever before
      (for the first read); one read consumes all pending pulses.
    - ``"never"``: like ``"once"`` but pulses before creation do not count.
    - ``"always"``: each pulse gives exactly one true read, counting every pulse since
      ``fluent`` was created.

    It pulses on every pulse of ``fluent``. ``peek_value()`` does not consume. Not
    reentrant: create one per waiter. Nets over it are not cacheable.
    """
    if handle_missed not in _HANDLE_MISSED:
        raise ValueError(
            f"pulsed(handle_missed={handle_missed!r}): expected one of "
            f"{', '.join(map(repr, _HANDLE_MISSED))}"
        )
    if not isinstance(fluent, Fluent):
        raise TypeError(f"pulsed() needs a Fluent to watch, got {fluent!r}")
    return _PulseFluent(fluent, handle_missed)


# --------------------------------------------------------------------------- waiting


@overload
async def wait_for(fluent: Fluent[T], timeout: float | None = None) -> T | None: ...


@overload
async def wait_for(fluent: T, timeout: float | None = None) -> T | None: ...


async def wait_for(fluent: Any, timeout: float | None = None) -> Any:
    """Wait until ``fluent.value`` is truthy and return that value.

    Returns at once if it already is. Every pulse re-checks (a pulse that leaves the value
    falsy does not release). Returns ``None`` when ``timeout`` seconds of the current time
    (the current :class:`~cpl.Timeline`'s, else the loop clock's) pass first, no
    exception. Each check reads ``value`` exactly once, so on a pulse fluent a check
    consumes. Given a non-fluent, returns it if truthy and raises ``ValueError`` if
    falsy (it could never change).

    Blocks through :func:`~cpl._scheduling.block_until`: a suspended task re-checks after
    wake-up and keeps its original deadline; cancellation (evaporation) propagates, and the
    waiter is always unregistered from the fluent. Works outside cpl tasks too.
    """
    if not isinstance(fluent, Fluent):
        if fluent:
            return fluent
        raise ValueError(
            f"wait_for called with a falsy non-fluent {fluent!r}: it can never become true; "
            "pass a Fluent to wait for its value to change"
        )
    deadline: float | None = None
    if timeout is not None:
        if timeout != timeout:
            raise ValueError("wait_for timeout is NaN; pass seconds >= 0 or None")
        deadline = current_time() + timeout
    value = fluent.value
    if value:
        return value
    task = CURRENT_TASK.get()
    if task is not None:
        task._waiting = fluent  # described as "waiting for <name>" when shown
    try:
        while True:
            fut = fluent._waiter()
            try:
                if deadline is None and (task is None or not task._suspend_requested):
                    # block_until's common case, inlined: a waiting task then holds one
                    # coroutine frame less (~250 B). Same semantics as block_until.
                    if task is not None:
                        task._blocked_on = fut
                    try:
                        await fut
                    except asyncio.CancelledError:
                        if (
                            task is not None
                            and task.evaporation is not None
                            and asyncio.current_task() is task._atask
                        ):
                            raise task.evaporation from None
                        raise
                    finally:
                        if task is not None:
                            task._blocked_on = None
                elif not await block_until(fut, deadline) and not fut.done():
                    return None  # the deadline passed
            finally:
                fluent._remove_waiter(fut)
            # Woken, or the deadline's timer resolved ``fut``: (one last) check.
            value = fluent.value
            if value:
                return value
            if deadline is not None and current_time() >= deadline:
                return None  # block_until said the deadline passed (no local: a smaller frame)
    finally:
        if task is not None:
            task.waiting_on = None


def _resolve(fut: asyncio.Future[None]) -> None:
    if not fut.done():
        fut.set_result(None)


class _Whenever(AsyncIterator[Any]):
    """Async iterator yielding ``await wait_for(fluent)`` forever.

    Holds no waiter between iterations, so leaving the ``async for`` needs no cleanup.
    """

    __slots__ = ("_fluent", "_started")

    def __init__(self, fluent: Any) -> None:
        self._fluent = fluent
        self._started = False

    def __aiter__(self) -> _Whenever:
        return self

    async def __anext__(self) -> Any:
        if self._started:
            # A checkpoint between iterations: other tasks run, suspension and evaporation
            # arrive, even when the fluent stays true.
            loop = asyncio.get_running_loop()
            fut: asyncio.Future[None] = loop.create_future()
            loop.call_soon(_resolve, fut)
            await block_until(fut)
        else:
            self._started = True
        return await wait_for(self._fluent)


def whenever(fluent: Any) -> AsyncIterator[Any]:
    """``async for value in whenever(f):`` runs the body each time ``wait_for(f)`` returns.

    Never ends by itself: ``break`` (or ``return``) leaves it; nothing stays registered on
    the fluent between iterations. Like CRAM, on a value fluent that *stays* true the body
    runs over and over (a busy loop); to react to changes, watch ``pulsed(f)`` (one pulse
    fluent per watcher) instead. Deliberate difference: CRAM's threads are preempted, asyncio
    tasks are not, so before each later iteration this yields to the event loop once (a cpl
    checkpoint): a busy ``whenever`` wastes CPU but does not starve other tasks, and
    suspension and evaporation reach it there.
    """
    return _Whenever(fluent)
