"""skidimm: which traction mode is a skid-steer robot in? (docs/python.md)

The C++ engine (an Interacting Multiple Model estimator over a bank of
motion-model plugins) from Python:

    import skidimm
    imm = skidimm.Imm.from_yaml("configs/ltc_terrains.yaml")
    est = imm.step(t, u, z)               # one step; numpy arrays
    out = imm.run(t, u, z)                # whole arrays in C++: the columns `skidimm run` writes
    report = skidimm.eval("configs/ltc_terrains.yaml", ["logs/"])   # `skidimm eval --json`

Plugins are found as the ``skidimm`` tool finds them: ``plugin_paths``, the
bank's ``plugin_paths``, ``$SKIDIMM_PLUGIN_PATH``, then the plugins bundled
next to this package (in a build tree and in an install alike).

Errors are :class:`Error` subclasses carrying the C++ message (file, line,
field): :class:`ConfigError` and :class:`LogError` are also ``ValueError``.
The GIL is released while C++ runs.
"""

import json as _json
import os as _os
import tempfile as _tempfile
import warnings as _warnings

import numpy as _np

from . import _skidimm as _native
from ._models import MotionModel, register_model, registered_models
from ._models import models_for as _models_for
from ._skidimm import (  # noqa: F401  (re-exported)
    Checkpoint,
    ConfigError,
    Error,
    Estimate,
    FitError,
    LogError,
    LogResult,
    PluginError,
    evaluate_expression,
    expand_log_argument,
    group_name,
    group_names,
    module_plugin_directory,
    parse_log_spec,
    plugin_search_path,
    plugins,
    read_csv,
)

__version__ = _native.__version__

__all__ = [
    "Bank", "Checkpoint", "Imm", "LiveLog", "MotionModel", "register_model", "registered_models", "run", "run_log", "simulate",
    "simulate_models", "fit", "eval", "evaluate_log", "eval_report", "to_frame", "Error", "ConfigError", "LogError",
    "PluginError", "FitError", "Estimate", "LogResult", "plugins", "plugin_search_path", "module_plugin_directory",
    "read_csv", "expand_log_argument", "parse_log_spec", "group_name", "group_names", "evaluate_expression",
]

_AGGREGATES = ("mean(", "std(", "rms(", "diff_std(")  # "std(" finds diff_std( too; named for the reader


def _paths(paths):
    """Plugin paths as ``--plugin-path`` takes them: each must exist (a typo would search nothing, silently)."""
    if paths is None:
        return []
    if isinstance(paths, (str, _os.PathLike)):
        paths = [paths]
    paths = [_os.fspath(p) for p in paths]
    for p in paths:
        if not _os.path.exists(p):
            raise Error(f"plugin_paths: {p!r}: no such directory or plugin file")
    return paths


def _rate(rate):
    return 0.0 if rate is None else float(rate)


class Bank(_native.Bank):
    """A bank: its YAML configuration and one motion model per mode.

    ``Bank(file, plugin_paths=(), models=None)`` loads ``file`` and its
    plugins. ``models`` maps model names to :class:`MotionModel` subclasses
    (added to those registered with :func:`register_model`), for modes whose
    ``model:`` names a Python model.

    Read-only: ``name``, ``file``, ``states``, ``angles``, ``inputs``,
    ``measurements``, ``modes``, ``models`` (each mode's model name),
    ``model_sources`` (where each mode's model came from: plugin file and
    version, or Python model), ``classes``, ``columns``, ``sampling_rate``,
    ``decision``;
    ``parameters(mode)`` gives a mode's model parameters.
    """

    def __init__(self, file, plugin_paths=(), models=None):
        super().__init__(_os.fspath(file), _paths(plugin_paths), _models_for(models))


def _bank(bank, plugin_paths=(), models=None):
    if isinstance(bank, _native.Bank):
        return bank
    return Bank(bank, plugin_paths, models)


def _warn_of_rate(bank, rate):
    """As ``skidimm run --rate`` and ``eval --rate`` warn: a rate unlike the bank's, where it aggregates."""
    why = _native.rate_unlike_the_banks(bank, _rate(rate))
    if why:
        _warnings.warn(f"rate={rate:g} Hz steps bank {bank.name!r} {why}. Leave rate out, or fit the bank at this rate "
                       "(skidimm.fit(rate=...), which writes it as the bank's sampling.rate)", stacklevel=3)


def _column(frame, text, what):
    """A bank column (a name, or an expression of names) from a DataFrame."""
    if text in frame.columns:
        return _np.asarray(frame[text], dtype=float)
    if any(a in text.replace(" ", "") for a in _AGGREGATES):
        raise LogError(f"{what} '{text}' aggregates rows of a filter step, which needs the log reader and a "
                       "sampling rate: use skidimm.run_log on the log's files")
    names = {c: _np.asarray(frame[c], dtype=float) for c in frame.columns
             if isinstance(c, str) and c.isidentifier()}
    try:
        return evaluate_expression(text, names)
    except KeyError as e:
        raise LogError(f"{what} '{text}': the frame has no such column ({e.args[0]})") from None


def _refuse_datetimes(t):
    """``t``, unless it holds datetimes (numpy or pandas), which read as numbers are nanoseconds: refused, with the
    conversion to seconds."""
    if getattr(getattr(t, "dtype", None), "kind", "") in ("m", "M"):  # pandas' zoned datetimes too
        raise ValueError("t: datetime values; skidimm takes times in seconds, which "
                         "(t - t[0]) / np.timedelta64(1, 's') gives")
    return t


class Imm(_native.Imm):
    """The IMM estimator (imm.h) over a :class:`Bank`.

    ``Imm(bank, kernel="fastest", decision=None)``: ``bank`` is a Bank or a
    bank file; ``decision`` overrides the bank's ``decision:`` settings
    (``{"enter": 0.9, "leave": 0.05, "min_hold": 1.0, "stale_after": 10.0}``).

    ``step(t, u, z)`` runs one cycle and returns an :class:`Estimate`
    (numpy arrays: ``mode_probabilities``, ``state``, ``covariance``,
    ``mode_states``, ``mode_covariances``, ``log_likelihoods``, ``nis``;
    ``mode``, ``decision``, ``status``...). ``run`` runs whole arrays in C++.
    """

    def __init__(self, bank, kernel="fastest", decision=None, plugin_paths=(), models=None):
        super().__init__(_bank(bank, plugin_paths, models), kernel, decision)

    @classmethod
    def from_yaml(cls, file, plugin_paths=(), models=None, **options):
        """Loads a bank file and its plugins (like ``skidimm::Imm::from_yaml``)."""
        return cls(Bank(file, plugin_paths, models), **options)

    def run(self, t, u=None, z=None, *, smooth=False, lag=None, truth=None, reset=True):
        """Runs the IMM over whole arrays in C++ (no Python per row).

        ``t``: n times (s, increasing); ``u``: n x inputs; ``z``: n x
        measurements, NaN where not measured (bank order). Or ``t`` is a
        pandas DataFrame whose columns the bank names (``columns:``; plain
        names or expressions of them, one filter step per row), and a
        DataFrame comes back.

        Returns the columns ``skidimm run`` writes, in its order: ``t``,
        ``mu_<mode>``, each state, ``var_<state>``, ``mode``, ``decision``,
        ``truth_mode`` (with ``truth`` labels, or the frame's truth column)
        and ``status`` (numpy arrays; text as str objects).

        ``smooth=True``: fixed-interval smoothing over the whole run; ``lag=s``:
        fixed-lag smoothing (imm_smoother.h). ``reset=False`` continues the
        filter (and the decision) from the last step, for logs in chunks.
        """
        frame = None
        if u is None and z is None and hasattr(t, "columns"):
            frame = t
            bank = self.bank
            columns = bank.columns
            if columns["time"] not in frame.columns:
                raise LogError(f"the frame has no time column '{columns['time']}' (bank '{bank.name}')")
            t = _refuse_datetimes(frame[columns["time"]])
            t = _np.asarray(t, dtype=float) / columns["time_units_per_second"]  # columns.time_unit: in seconds
            n = len(t)
            u = _np.empty((n, len(bank.inputs)))
            for i, text in enumerate(columns["inputs"]):
                u[:, i] = _column(frame, text, f"input '{bank.inputs[i]}'")
            z = _np.empty((n, len(bank.measurements)))
            for i, text in enumerate(columns["measurements"]):
                z[:, i] = _column(frame, text, f"measurement '{bank.measurements[i]}'")
            if truth is None and columns["truth_mode"] and columns["truth_mode"] in frame.columns:
                truth = [("" if v is None or (isinstance(v, float) and v != v) else str(v))
                         for v in frame[columns["truth_mode"]]]
        else:
            t = _refuse_datetimes(t)
        out = self._run(t, u, z, smooth=smooth, lag=lag, truth=truth, reset=reset)
        if frame is not None:
            return to_frame(out, index=frame.index)
        return out


def to_frame(columns, index=None):
    """A pandas DataFrame of the columns ``run``/``run_log``/``simulate`` return."""
    import pandas as pd

    frame = pd.DataFrame(columns, copy=False)
    if index is not None:
        frame.index = index
    return frame


def run(bank, t, u=None, z=None, *, smooth=False, lag=None, truth=None, decision=None, plugin_paths=(), models=None):
    """``Imm(bank).run(...)``: a fresh IMM over whole arrays (or a DataFrame)."""
    return Imm(bank, decision=decision, plugin_paths=plugin_paths, models=models).run(
        t, u, z, smooth=smooth, lag=lag, truth=truth)


def run_log(bank, inputs, *, rate=None, smooth=False, lag=None, decision=None, plugin_paths=(), models=None):
    """What ``skidimm run --input ...`` writes, as columns (numbers exactly equal).

    ``inputs``: the log's files as ``--input`` takes them (a string or a
    list: ``[LABEL=]FILE[@OFFSET][+FILE...]``), read by the CLI's log reader
    (multi-rate files, expressions, aggregates, ``rate``).
    """
    if isinstance(inputs, (str, _os.PathLike)):
        inputs = [inputs]
    loaded = _bank(bank, plugin_paths, models)
    _warn_of_rate(loaded, rate)
    return _native.run_log(loaded, [_os.fspath(i) for i in inputs], _rate(rate), smooth, lag, decision)


class LiveLog(_native.LiveLog):
    """A log pushed row by row while it is read: a robot's sensors, live.

    ``LiveLog(bank, tables, *, rate=None, offsets=None)``. ``tables`` maps
    each sensor stream's name to its columns, the bank's time column among
    them, as the files of a multi-rate log: ``{"pro": ["time", "curL",
    "curR", "velL", "velR"], "imu": ["time", "wx", "wy", "wz", "ax", "ay",
    "az"]}``. ``offsets`` maps a table's name to seconds added to its times.

    ``push(table, row)`` appends a row (one number per column, NaN for an
    empty cell; a 2-D array pushes several) to a table, by name or index;
    rows of a table come in time order, tables in any order.
    ``steps()`` gives ``(t, u, z)``, the filter steps the rows so far
    complete, as ``skidimm run`` reads the same rows from files, bit for bit
    (aggregates such as ``mean(wz)`` and ``log(std(az))`` over each step
    included): ``imm.run(t, u, z, reset=False)``, or ``imm.step`` on each.
    A step waits for a row at or after it from every table not closed:
    ``close(table)`` when a sensor ends, ``close()`` at the end of the log.
    ``waiting_for`` is the table the next step waits for and the time of
    its last row (a sensor that stopped without ``close``), or ``None``.
    ``ended``, ``describe_stats()``, ``unmeasured()`` and
    ``max_queued_rows`` as ``skidimm run`` reports them (docs/python.md).
    """

    def __init__(self, bank, tables, *, rate=None, offsets=None, plugin_paths=(), models=None):
        loaded = bank if isinstance(bank, _native.Bank) else Bank(bank, plugin_paths, models)
        offsets = dict(offsets or {})
        if isinstance(tables, dict):
            tables = list(tables.items())
        unknown = set(offsets) - {name for name, _ in tables}
        if unknown:
            raise ValueError(f"offsets: no table named {sorted(unknown)[0]!r}")
        _warn_of_rate(loaded, rate)
        super().__init__(loaded, [(str(name), [str(c) for c in columns], float(offsets.get(name, 0.0)))
                                  for name, columns in tables], _rate(rate))


def simulate(scenario, *, seed=None, duration=None, output=None):
    """``skidimm simulate --scenario``: the simulated log as columns.

    With ``output`` the CSV is also kept there. Numbers are read back
    exactly; ``mode`` is text.
    """
    def go(path):
        _native.simulate_scenario(_os.fspath(scenario), path, seed, 0.0 if duration is None else float(duration))
        return read_csv(path)

    if output is not None:
        return go(_os.fspath(output))
    with _tempfile.TemporaryDirectory(prefix="skidimm_") as directory:
        return go(_os.path.join(directory, "log.csv"))


def simulate_models(bank, inputs_from, *, seed=1, rate=None, output=None, plugin_paths=(), models=None):
    """``skidimm simulate --bank --inputs-from``: the bank's own models driven by a log."""
    loaded = _bank(bank, plugin_paths, models)

    def go(path):
        _native.simulate_models(loaded, _os.fspath(inputs_from), path, int(seed), _rate(rate))
        return read_csv(path)

    if output is not None:
        return go(_os.fspath(output))
    with _tempfile.TemporaryDirectory(prefix="skidimm_") as directory:
        return go(_os.path.join(directory, "log.csv"))


def evaluate_log(bank, log, *, rate=None, smooth=False, lag=None, plugin_paths=(), models=None):
    """One log scored as ``skidimm eval`` scores it: a picklable :class:`LogResult`."""
    loaded = _bank(bank, plugin_paths, models)
    _warn_of_rate(loaded, rate)
    return _native.evaluate_log(loaded, log, _rate(rate), smooth, lag)


def eval_report(bank, groups, output="dict", range_for=None):
    """``skidimm eval``'s report for ``groups`` ([(name, [LogResult, ...])]), reduced in that order.

    ``output``: ``"dict"`` (the JSON parsed), ``"json"`` (the text
    ``skidimm eval --json`` prints) or ``"table"`` (the text it prints
    without ``--json``). ``range_for`` is ``--range-for``: a dict of
    logs per class for the range of accuracy another set of logs would
    score (default: as many as were scored).
    """
    return _eval_report(bank, groups, output, range_for=range_for)


def _range_counts(range_for):
    """``range_for`` checked as ``--range-for`` is, before any log is scored: {class: whole count >= 1}."""
    if range_for is None:
        return {}
    if not isinstance(range_for, dict) or not range_for:
        raise ValueError("range_for must be a dict of logs per class, {'ASPHALT': 2, ...}")
    for name, count in range_for.items():
        if not isinstance(name, str) or not name or any(c.isspace() for c in name):
            raise ValueError(f"range_for: {name!r} is not a class's name")
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= _native.MOST_LOGS_PER_CLASS:
            raise ValueError(f"range_for: {name!r}: {count!r} is not a whole number of logs from 1 to "
                             f"{_native.MOST_LOGS_PER_CLASS}")
    return dict(range_for)



def _eval_report(bank, groups, output, spliced=False, range_for=None):
    counts = _range_counts(range_for)
    bank = _bank(bank)
    groups = [(name, list(logs)) for name, logs in groups]
    # A measurement a log never gave, or not for a long stretch, leaves it scored on the others: warned, as the
    # CLI warns (in a splice, each line names its log).
    for _, logs in groups:
        for log in logs:
            for line in log.unmeasured:
                _warnings.warn(line if spliced else f"{log.source}: {line}", stacklevel=4)
    text, table, problem = _native.eval_report(groups, bank.states, bank.classes, bank, counts)
    if problem:
        # The report keeps every figure and says it in the range's place, as the CLI's does before it fails.
        _warnings.warn(f"range_for: {problem}", stacklevel=3)
    if output == "json":
        return text
    if output == "table":
        return table
    if output == "dict":
        return _json.loads(text)
    raise ValueError("output must be 'dict', 'json' or 'table'")


def eval(bank, inputs, *, rate=None, smooth=False, lag=None, splice=False, output="dict",  # noqa: A001
         skip_unpaired=False, range_for=None, plugin_paths=(), models=None):
    """``skidimm eval --bank B --input ...``: each argument a group of logs (files, directories, patterns).

    ``skip_unpaired=True`` is ``--skip-unpaired``: a pattern's runs that some
    of its files lack are left out with a warning instead of an error.
    ``splice=True`` is ``--splice``: the logs scored as one run spliced end to
    end, the groups taking turns (not with ``smooth`` or ``lag``).
    ``range_for={'ICE': 4, 'SNOW': 9}`` is ``--range-for``: the range of
    accuracy another set of that many logs of each class would score.
    Returns what ``skidimm eval --json`` prints, parsed (``output="dict"``),
    or its text (``"json"``), or the table (``"table"``). The metrics and
    their reduction are the evaluation library's, which the CLI uses too.
    For many logs on many machines, see :mod:`skidimm.dask`.
    """
    if isinstance(inputs, (str, _os.PathLike)):
        inputs = [inputs]
    _range_counts(range_for)  # before the work, as the CLI refuses a bad --range-for
    loaded = _bank(bank, plugin_paths, models)
    _warn_of_rate(loaded, rate)
    inputs = [_os.fspath(argument) for argument in inputs]
    if splice and (smooth or lag is not None):
        raise ValueError("splice scores the filter as it runs across each change, and smoothing would use the "
                         "measurements after the change: give one or the other")
    groups = {}  # by name, in the order of first appearance: arguments of one name are one group, as in the CLI
    for argument, name in zip(inputs, _native.group_names(inputs)):
        groups.setdefault(name, []).extend(expand_log_argument(argument, skip_unpaired))
    if splice:
        return _eval_report(loaded, _native.evaluate_spliced(loaded, list(groups.items()), _rate(rate)), output,
                            spliced=True, range_for=range_for)
    scored = [(name, [_native.evaluate_log(loaded, spec, _rate(rate), smooth, lag) for spec in specs])
              for name, specs in groups.items()]
    return _eval_report(loaded, scored, output, range_for=range_for)


def fit(bank, logs, *, mode="", name="", rate=None, objective="likelihood", window=0.0, loss="huber",
        loss_scale=3.0, hold_unexcited=False, shared=False, fit_r=False, full_q=False, output_noise=False,
        parameter_uncertainty=False, uncertainty_per_log=False, residual_correlation=False, pooled_q=False,
        partial_pooling=False, output_bank=None, skip_unpaired=False, plugin_paths=(), models=None):
    """``skidimm fit``: fits the bank's modes to ``logs`` (``--log`` arguments).

    Returns a dict: ``bank_yaml`` (the whole fitted bank, as
    ``--output-bank`` writes it, validated), ``entries`` (the fitted mode
    entries, as ``fit`` prints them), ``reports`` (per fitted mode: parameter
    values and standard deviations, one-step RMSE, Q, warnings...) and
    ``bank`` (the fitted :class:`Bank`, ready to run). With ``output_bank``
    the bank is also written there. Raises :class:`FitError` when the logs
    cannot determine the parameters. When stderr (file descriptor 2) is a
    terminal, a line there shows the mode being fitted, the solver's
    iterations, their rate and the time so far.
    """
    if isinstance(logs, (str, _os.PathLike)):
        logs = [logs]
    logs = [_os.fspath(log) for log in logs]
    options = _native.fit_options(objective, float(window), loss, float(loss_scale), hold_unexcited, shared, fit_r,
                                  full_q, output_noise, parameter_uncertainty, uncertainty_per_log,
                                  residual_correlation, pooled_q, partial_pooling)
    bank_file = _os.fspath(bank.file if isinstance(bank, _native.Bank) else bank)
    if isinstance(bank, _native.Bank):
        plugin_paths, models = bank.plugin_paths, bank.python_models
    if output_bank is not None:  # before the fit, which a bad path found after it would lose
        _native.check_output_path(_os.fspath(output_bank), "output_bank")
    fresh = Bank(bank_file, plugin_paths, models)  # fitted in place
    renaming = _native.renaming_problem(fresh, mode, name)  # before the fit, which writing the bank finds after
    if renaming:
        raise ConfigError(f"name={name!r}: {renaming}")
    data = _native.load_fit_logs(fresh, logs, mode, _rate(rate), skip_unpaired)
    for note in _native.fit_notes(fresh, data):  # what `skidimm fit` says before it fits
        _warnings.warn(note, stacklevel=2)
    fitted = _native.fit_in_place(fresh, data, options)
    return _fit_result(fresh, fitted, options, mode, name, output_bank, plugin_paths, models,
                       "skidimm.fit(" + ", ".join(repr(log) for log in logs) + ")", _rate(rate))


def _fit_result(bank, fitted, options, mode, name, output_bank, plugin_paths, models, call, rate):
    header = ["Written by skidimm fit (Python); reproduce with:", "  " + call]

    def go(path):
        entries, text = _native.fit_texts(bank, fitted, options, mode, name, header, path, rate)
        loaded = Bank(path, plugin_paths, models)
        return loaded, entries, text

    if output_bank is not None:
        loaded, entries, text = go(_os.fspath(output_bank))
    else:
        with _tempfile.TemporaryDirectory(prefix="skidimm_") as directory:
            loaded, entries, text = go(_os.path.join(directory, _os.path.basename(_os.fspath(bank.file))))
    modes = bank.modes
    reports = {modes[j]: entry["report"] for j, entry in sorted(fitted.items())}
    return {"bank_yaml": text, "entries": entries, "reports": reports, "bank": loaded}
