"""Motion models written in Python (docs/python.md, "Motion models in Python").

A subclass of :class:`MotionModel` is a mode's model like a compiled plugin:
name it in a bank's ``model:`` and register it (``register_model``) or pass it
to ``Bank(..., models={name: cls})``. It is the slow path, for prototyping:
the engine calls ``predict`` from C++ once per mode per step, taking the GIL
back for each call (a few microseconds each; docs/python.md has the figures).
Write the C++ plugin (docs/writing-a-model-plugin.md) once the model is right.
"""

import threading

__all__ = ["MotionModel", "register_model", "registered_models"]


def _default(function):
    """Marks a base-class method the engine should treat as not overridden."""
    function.__skidimm_default__ = True
    return function


class MotionModel:
    """Base class of Python motion models.

    Class attributes (or instance attributes set in ``__init__``):

    ``states``, ``inputs``
        Names in the bank's order; left empty, the bank's own (a model whose
        dimensions come from the bank, like ``linear_features``).
    ``angles``
        The states that are angles in radians (wrapped to [-pi, pi)).
    ``shared_parameters``
        Keys this model takes from the bank's ``shared:`` block.
    ``fit_parameters``
        Keys of ``self.params`` that ``skidimm.fit`` may change: floats, or
        C-contiguous float64 arrays (changed in place, row-major order).

    The constructor receives the mode's parameters (``params:`` and the
    shared ones it takes) as a dict: a number as ``float``, a list as a 1-D
    ``numpy`` array, a matrix as a 2-D one, text as a list of ``str``. The
    default keeps it as ``self.params``. Raise ``ValueError`` for bad
    parameters: the bank fails to load with the file, line and mode.

    Methods the engine calls (x, u are 1-D float64 arrays; dt in seconds):

    ``predict(x, u, dt) -> x_next``
        Required. ``predict(x, u, 0)`` must return ``x``.
    ``jacobian(x, u, dt) -> F``
        Optional (n x n, d predict / d x). Without it the engine
        differentiates ``predict`` numerically (n + 1 calls more per step).
    ``process_noise(Q, x, u, dt) -> Qd``
        Optional; the default is ``Q * dt``, as for plugins.

    An exception raised by any of them stops the step's mode (the engine
    rejects it, as for a failing plugin), no further Python model is called,
    and the call that ran the engine (``step``, ``run``, ``eval``...)
    re-raises it.
    """

    states = ()
    inputs = ()
    angles = ()
    shared_parameters = ()
    fit_parameters = ()

    def __init__(self, params):
        self.params = params

    @_default
    def predict(self, x, u, dt):  # pragma: no cover - the engine refuses a model without predict
        raise NotImplementedError("a skidimm.MotionModel must define predict(x, u, dt)")

    @_default
    def jacobian(self, x, u, dt):  # pragma: no cover - never called: the engine differentiates predict
        raise NotImplementedError

    @_default
    def process_noise(self, q, x, u, dt):  # pragma: no cover - never called: the engine uses Q * dt
        raise NotImplementedError


_lock = threading.Lock()
_registry = {}


def register_model(name, cls=None):
    """Registers ``cls`` as the model a bank names ``name`` (``model: name``).

    Usable as a decorator: ``@skidimm.register_model("my_model")``. A
    registered name is used before a plugin of the same name. Registration is
    per process: on a Dask cluster, pass ``models={name: cls}`` instead (the
    class must be importable on the workers).
    """
    def add(cls):
        if not (isinstance(cls, type) and issubclass(cls, MotionModel)):
            raise TypeError(f"register_model: {cls!r} is not a subclass of skidimm.MotionModel")
        with _lock:
            _registry[str(name)] = cls
        return cls

    return add if cls is None else add(cls)


def registered_models():
    """The registered Python models, by name."""
    with _lock:
        return dict(_registry)


def models_for(models):
    """The registered models updated with ``models`` (a dict, or None)."""
    merged = registered_models()
    if models:
        for name, cls in dict(models).items():
            if not (isinstance(cls, type) and issubclass(cls, MotionModel)):
                raise TypeError(f"models[{name!r}]: {cls!r} is not a subclass of skidimm.MotionModel")
            merged[str(name)] = cls
    return merged
