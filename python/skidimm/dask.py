"""Fleet-scale ``eval`` and ``fit`` on a Dask cluster (docs/python.md, "Many logs on Dask").

Each log is independent work: a worker reads it from shared storage, runs
the bank's IMM over it and scores it (``eval``), or splits it into the
segments of each mode (``fit``). What travels back is small: a log's
:class:`skidimm.LogResult` (its metrics, a few kilobytes), or a mode's
fitted parameters. The reduction happens on the client, in the order
``skidimm eval`` and ``skidimm fit`` use (arguments in order, each
directory's logs sorted by name), by the evaluation library the CLI uses,
so the figures are those the CLI prints, to the last digit.

Workers load the bank once per process (and its plugins, found as
everywhere: ``plugin_paths``, the bank's, ``$SKIDIMM_PLUGIN_PATH``, the
plugins installed next to the package). Every machine needs the package,
the plugins and the same paths to the bank and the logs.

Dask starts worker processes by spawning: the driving program must be a
file whose work is under ``if __name__ == "__main__":``.
"""

import os
import threading
import warnings

import skidimm

__all__ = ["eval", "evaluate_logs", "fit"]

_banks = {}
_banks_lock = threading.Lock()


def _key(bank_file, plugin_paths, models):
    names = tuple(sorted((name, f"{cls.__module__}.{cls.__qualname__}") for name, cls in (models or {}).items()))
    return (os.path.abspath(bank_file), tuple(plugin_paths), names)


def _worker_bank(bank_file, plugin_paths, models):
    """The bank, loaded once per worker process (read-only afterwards)."""
    key = _key(bank_file, plugin_paths, models)
    with _banks_lock:
        bank = _banks.get(key)
        if bank is None:
            bank = skidimm.Bank(bank_file, plugin_paths, models)
            _banks[key] = bank
        return bank


def _evaluate(spec, bank_file, plugin_paths, models, rate, smooth, lag):
    bank = _worker_bank(bank_file, plugin_paths, models)
    # The client warned of a rate unlike the bank's, once (evaluate_logs).
    return skidimm._native.evaluate_log(bank, spec, skidimm._rate(rate), smooth, lag)


def _evaluate_spliced(groups, bank_file, plugin_paths, models, rate):
    bank = _worker_bank(bank_file, plugin_paths, models)
    return skidimm._native.evaluate_spliced(bank, groups, skidimm._rate(rate))


def _bank_arguments(bank, plugin_paths, models):
    if isinstance(bank, skidimm._native.Bank):
        return os.fspath(bank.file), list(bank.plugin_paths), dict(bank.python_models)
    return os.path.abspath(os.fspath(bank)), [os.path.abspath(os.fspath(p)) for p in (plugin_paths or [])], models


def evaluate_logs(client, bank, inputs, *, rate=None, smooth=False, lag=None, skip_unpaired=False, plugin_paths=(),
                  models=None):
    """Scores every log of ``inputs`` on the cluster: [(group name, [LogResult, ...])] in the CLI's order."""
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    bank_file, plugin_paths, models = _bank_arguments(bank, plugin_paths, models)
    if rate:
        skidimm._warn_of_rate(skidimm._bank(bank, plugin_paths, models), rate)
    groups, specs = [], []
    inputs = [os.fspath(argument) for argument in inputs]
    for argument, name in zip(inputs, skidimm._native.group_names(inputs)):
        expanded = skidimm.expand_log_argument(argument, skip_unpaired)  # lists directories here, on the client
        groups.append((name, len(expanded)))
        specs.extend(expanded)
    futures = client.map(_evaluate, specs, bank_file=bank_file, plugin_paths=plugin_paths, models=models, rate=rate,
                         smooth=smooth, lag=lag, pure=False)
    results = client.gather(futures)  # in submission order, whatever finished first
    out, at = {}, 0  # arguments of one name are one group, as in the CLI
    for name, count in groups:
        out.setdefault(name, []).extend(results[at:at + count])
        at += count
    return list(out.items())


def eval(client, bank, inputs, *, rate=None, smooth=False, lag=None, splice=False, output="dict",  # noqa: A001
         skip_unpaired=False, range_for=None, plugin_paths=(), models=None):
    """``skidimm eval --bank B --input ...`` with each log scored on the cluster.

    Same arguments and result as :func:`skidimm.eval`; ``client`` is a
    ``distributed.Client``. Only the reduction (merging per-log metrics,
    formatting) runs here, on the client. ``splice=True`` (``--splice``)
    scores the logs as one run spliced end to end: one filter through every
    log in turn, which one worker runs (reading the logs where they are
    stored) while the client waits.
    """
    skidimm._range_counts(range_for)  # before the work, as the CLI refuses a bad --range-for
    if not splice:
        groups = evaluate_logs(client, bank, inputs, rate=rate, smooth=smooth, lag=lag, skip_unpaired=skip_unpaired,
                               plugin_paths=plugin_paths, models=models)
        bank_file, plugin_paths, models = _bank_arguments(bank, plugin_paths, models)
        return skidimm.eval_report(skidimm.Bank(bank_file, plugin_paths, models), groups, output, range_for)
    if smooth or lag is not None:
        raise ValueError("splice scores the filter as it runs across each change, and smoothing would use the "
                         "measurements after the change: give one or the other")
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    bank_file, plugin_paths, models = _bank_arguments(bank, plugin_paths, models)
    loaded = skidimm.Bank(bank_file, plugin_paths, models)
    if rate:
        skidimm._warn_of_rate(loaded, rate)
    groups = {}  # arguments of one name are one group, as in the CLI
    inputs = [os.fspath(argument) for argument in inputs]
    for argument, name in zip(inputs, skidimm._native.group_names(inputs)):
        groups.setdefault(name, []).extend(skidimm.expand_log_argument(argument, skip_unpaired))
    future = client.submit(_evaluate_spliced, list(groups.items()), bank_file=bank_file, plugin_paths=plugin_paths,
                           models=models, rate=rate, pure=False)
    return skidimm._eval_report(loaded, future.result(), output, spliced=True, range_for=range_for)


def _segments(spec, bank_file, plugin_paths, models, mode, rate):
    bank = _worker_bank(bank_file, plugin_paths, models)
    return skidimm._native.mode_segments(bank, spec, mode, rate)


def _modes_in(segments):
    return [j for j, logs in segments if logs]


def _fit_notes(segments, bank_file, plugin_paths, models):
    return skidimm._native.fit_notes(_worker_bank(bank_file, plugin_paths, models), segments, False)


def _fit(bank_file, plugin_paths, models, options, modes, *segments):
    """Fits `modes` (None: every mode in the segments) of a fresh bank to their segments, in log order."""
    bank = skidimm.Bank(bank_file, plugin_paths, models)  # fitted in place: never the cached one
    by_mode = {}
    for log in segments:
        for j, logs in log:
            if modes is None or j in modes:
                by_mode.setdefault(j, []).extend(logs)
    data = [(j, by_mode[j]) for j in sorted(by_mode)]
    return skidimm._native.fit_in_place(bank, data, options)


def fit(client, bank, logs, *, mode="", name="", rate=None, objective="likelihood", window=0.0, loss="huber",
        loss_scale=3.0, hold_unexcited=False, shared=False, fit_r=False, full_q=False, output_noise=False,
        parameter_uncertainty=False, uncertainty_per_log=False, residual_correlation=False, pooled_q=False,
        partial_pooling=False, output_bank=None, skip_unpaired=False, plugin_paths=(), models=None):
    """``skidimm fit`` with the logs read on the cluster and each mode fitted on its own worker.

    Same arguments and result as :func:`skidimm.fit`. Reading and splitting
    the logs is per log; fitting is per mode (each mode's fit depends only on
    its own segments), except when the fit couples the modes (``shared``
    bank-level parameters, one ``fit_r`` for the bank, ``partial_pooling``
    of the modes' estimates), which runs as one task. The segments go from
    the workers that read them to the worker that fits their mode, not
    through the client.
    """
    if isinstance(logs, (str, os.PathLike)):
        logs = [logs]
    bank_file, plugin_paths, models = _bank_arguments(bank, plugin_paths, models)
    options = skidimm._native.fit_options(objective, float(window), loss, float(loss_scale), hold_unexcited, shared,
                                          fit_r, full_q, output_noise, parameter_uncertainty, uncertainty_per_log,
                                          residual_correlation, pooled_q, partial_pooling)
    rate = 0.0 if rate is None else float(rate)
    if output_bank is not None:  # before the fit, which a bad path found after it would lose
        skidimm._native.check_output_path(os.fspath(output_bank), "output_bank")
    renaming = skidimm._native.renaming_problem(skidimm.Bank(bank_file, plugin_paths, models), mode, name)
    if renaming:  # before the fit, which writing the bank finds after it
        raise skidimm.ConfigError(f"name={name!r}: {renaming}")
    specs = []
    for argument in logs:
        specs.extend(skidimm.expand_log_argument(os.fspath(argument), skip_unpaired))
    segments = client.map(_segments, specs, bank_file=bank_file, plugin_paths=plugin_paths, models=models, mode=mode,
                          rate=rate, pure=False)
    modes_per_log = client.gather(client.map(_modes_in, segments, pure=False))
    if not any(modes_per_log):
        raise skidimm.Error("no logs to fit")
    # What `skidimm fit` says before it fits: of each log where it was read, then of the bank.
    notes = client.gather(client.map(_fit_notes, segments, bank_file=bank_file, plugin_paths=plugin_paths,
                                     models=models, pure=False))
    notes.append(skidimm._native.fit_notes(skidimm.Bank(bank_file, plugin_paths, models), []))
    for note in (note for of_log in notes for note in of_log):
        warnings.warn(note, stacklevel=2)
    if shared or fit_r or partial_pooling:  # the modes are fitted jointly, or pooled together
        tasks = [client.submit(_fit, bank_file, plugin_paths, models, options, None, *segments, pure=False)]
    else:
        tasks = []
        for j in sorted({j for modes in modes_per_log for j in modes}):
            mine = [s for s, modes in zip(segments, modes_per_log) if j in modes]
            tasks.append(client.submit(_fit, bank_file, plugin_paths, models, options, {j}, *mine, pure=False))
    fitted = {}
    for result in client.gather(tasks):
        fitted.update(result)
    if pooled_q and len(tasks) > 1:  # each mode fitted alone: pool their Q as fit_bank does, in mode order
        pooled = None
        for j in sorted(fitted):
            pooled = fitted[j]["q"].copy() if pooled is None else pooled + fitted[j]["q"]
        for entry in fitted.values():
            entry["q"] = pooled / len(fitted)
            entry["report"]["q"] = entry["q"]
    local = skidimm.Bank(bank_file, plugin_paths, models)
    for j, entry in fitted.items():
        skidimm._native.apply_fit(local, j, entry["parameters"], entry["q"], entry["r"], entry["fitted_inputs"],
                                  entry["parameter_covariance"], entry["residual_correlation"])
    call = "skidimm.dask.fit(" + ", ".join(repr(os.fspath(log)) for log in logs) + ")"
    return skidimm._fit_result(local, fitted, options, mode, name, output_bank, plugin_paths, models, call, rate)
