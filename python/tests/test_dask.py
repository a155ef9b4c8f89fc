"""skidimm.dask on a LocalCluster of worker processes: the figures equal the CLI's."""

import numpy as np
import pytest

import skidimm
from faulty_logs import a_row_written_twice

distributed = pytest.importorskip("distributed")
import skidimm.dask  # noqa: E402


@pytest.fixture(scope="module")
def client():
    # Worker processes are spawned; pytest's own __main__ is guarded, so they start cleanly.
    with distributed.LocalCluster(n_workers=3, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as client:
        yield client


def test_eval_on_the_cluster_equals_skidimm_eval_json(client, configs, cli, switching_logs):
    bank = configs / "ltc_terrains.yaml"
    arguments = [str(switching_logs), f"grass={switching_logs / 'run_05.csv'}"]
    text = skidimm.dask.eval(client, bank, arguments, output="json")
    # Every figure, group and log, as the CLI prints them (the same text, to the last digit).
    assert text == cli("eval", "--bank", bank, "--input", arguments[0], "--input", arguments[1], "--json")
    workers = client.run(lambda: sorted(skidimm.dask._banks))  # each worker loaded the bank once
    assert len(workers) == 3 and sum(1 for loaded in workers.values() if loaded) >= 2
    scored = skidimm.eval(bank, [switching_logs])["overall"]["mean_over_classes"]["range"]["logs_per_class"]
    counts = {name: 5 for name in scored}
    ranged = skidimm.dask.eval(client, bank, [switching_logs], range_for=counts, output="json")
    assert ranged == skidimm.eval(bank, [switching_logs], range_for=counts, output="json")
    report = skidimm.dask.eval(client, bank, [switching_logs], smooth=True)
    assert report == skidimm.eval(bank, [switching_logs], smooth=True)
    assert report["overall"]["logs"] == 24


def test_a_splice_on_the_cluster_equals_skidimm_eval_splice(client, configs, cli, switching_logs):
    bank = configs / "ltc_terrains.yaml"
    arguments = [f"asphalt={switching_logs / 'run_03.csv'}", f"grass={switching_logs / 'run_04.csv'}",
                 str(switching_logs / "run_05.csv")]
    text = skidimm.dask.eval(client, bank, arguments, splice=True, output="json")
    flags = [part for argument in arguments for part in ("--input", argument)]
    assert text == cli("eval", "--bank", bank, "--splice", *flags, "--json")
    with pytest.raises(ValueError, match="splice scores the filter as it runs across each change"):
        skidimm.dask.eval(client, bank, arguments, splice=True, lag=1.0)


def test_fit_on_the_cluster_equals_the_local_fit(client, configs, singular_logs):
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]] + [f"grass={p}" for p in singular_logs["grass"]]
    here = skidimm.fit(bank, logs, objective="window", window=0.5)
    there = skidimm.dask.fit(client, bank, logs, objective="window", window=0.5)

    def body(text):
        return [line for line in text.splitlines() if not line.startswith("# ")]

    assert body(there["bank_yaml"]) == body(here["bank_yaml"])
    assert there["entries"] == here["entries"]
    for mode in ("asphalt", "grass"):
        assert there["reports"][mode]["parameters"] == here["reports"][mode]["parameters"]


def test_fit_with_one_pooled_q_on_the_cluster_equals_the_local_fit(client, configs, singular_logs):
    """Each mode is fitted on a worker of its own; their Q is pooled after, as fit_bank pools it."""
    bank = configs / "ltc_terrains.yaml"
    logs = [f"asphalt={p}" for p in singular_logs["asphalt"]] + [f"grass={p}" for p in singular_logs["grass"]]
    own = skidimm.fit(bank, logs, objective="window", full_q=True)
    here = skidimm.fit(bank, logs, objective="window", full_q=True, pooled_q=True)
    there = skidimm.dask.fit(client, bank, logs, objective="window", full_q=True, pooled_q=True)
    def body(text):
        return [line for line in text.splitlines() if not line.startswith("# ")]

    assert body(there["bank_yaml"]) == body(here["bank_yaml"])
    assert there["entries"] == here["entries"]
    mean = (own["reports"]["asphalt"]["q"] + own["reports"]["grass"]["q"]) / 2
    assert not np.allclose(own["reports"]["asphalt"]["q"], own["reports"]["grass"]["q"], rtol=0.1)
    for mode in ("asphalt", "grass"):
        assert np.array_equal(here["reports"][mode]["q"], mean)
        assert np.array_equal(there["reports"][mode]["q"], mean)
        assert there["reports"][mode]["parameters"] == own["reports"][mode]["parameters"]
    with pytest.raises(skidimm.Error, match="pooled_q is an option of the window objective"):
        skidimm.fit(bank, logs, pooled_q=True)


def test_fit_with_partial_pooling_on_the_cluster_equals_the_local_fit(client, configs, tmp_path):
    """Partial pooling couples the modes: the cluster fits them in one task, as fit_bank does."""
    bank = configs / "ltc_terrains.yaml"
    logs = []
    for seed in (7100, 7101):  # 35 s: every one of the three terrains, a regime to pool over
        logs.append(str(tmp_path / f"run_{seed}.csv"))
        skidimm.simulate(configs / "scenarios" / "ltc_switching.yaml", seed=seed, duration=35.0, output=logs[-1])
    own = skidimm.fit(bank, logs, objective="window", parameter_uncertainty=True)
    here = skidimm.fit(bank, logs, objective="window", parameter_uncertainty=True, partial_pooling=True)
    there = skidimm.dask.fit(client, bank, logs, objective="window", parameter_uncertainty=True,
                             partial_pooling=True)

    def body(text):
        return [line for line in text.splitlines() if not line.startswith("# ")]

    assert body(there["bank_yaml"]) == body(here["bank_yaml"])
    # Each mode on its own worker keeps its parameter covariance and residual correlation too.
    own_there = skidimm.dask.fit(client, bank, logs, objective="window", parameter_uncertainty=True,
                                 residual_correlation=True)
    own_here = skidimm.fit(bank, logs, objective="window", parameter_uncertainty=True, residual_correlation=True)
    assert "parameter_covariance:" in own_here["bank_yaml"] and "residual_correlation:" in own_here["bank_yaml"]
    assert body(own_there["bank_yaml"]) == body(own_here["bank_yaml"])
    # Estimates closer together (each moves towards the mean, and with it, by their correlation, the others), and
    # none much less sure than before.
    terrains = ("asphalt", "grass", "crushed_concrete")
    for parameter in ("A[0,0]", "B[0,0]"):
        spread = {name: np.ptp([fitted["reports"][mode]["parameters"][parameter][0] for mode in terrains])
                  for name, fitted in (("own", own), ("pooled", here))}
        assert spread["pooled"] < spread["own"], (parameter, spread)
    for mode in terrains:
        for parameter, (value, sd) in here["reports"][mode]["parameters"].items():
            assert np.isfinite(value) and sd <= own["reports"][mode]["parameters"][parameter][1] * 1.5, (mode, parameter)
    assert here["reports"]["grass"]["parameters"]["A[0,0]"][0] != own["reports"]["grass"]["parameters"]["A[0,0]"][0]
    # A start bank with covariances, refitted without them: both drop them, as fit_bank does.
    start = tmp_path / "with_covariances.yaml"
    start.write_text(here["bank_yaml"])
    again_here = skidimm.fit(start, logs, objective="window")
    again_there = skidimm.dask.fit(client, start, logs, objective="window")
    assert "parameter_covariance:" not in again_here["bank_yaml"]
    assert body(again_there["bank_yaml"]) == body(again_here["bank_yaml"])
    with pytest.raises(skidimm.Error, match="partial_pooling weighs each mode's estimates by their covariance"):
        skidimm.fit(bank, logs, objective="window", partial_pooling=True)


def test_fit_on_the_cluster_warns_as_the_local_fit(client, configs, switching_logs, tmp_path):
    twice, bank = a_row_written_twice(configs, switching_logs, tmp_path)
    with pytest.warns(UserWarning) as here:
        skidimm.fit(bank, [str(twice)], objective="window")
    with pytest.warns(UserWarning) as there:
        skidimm.dask.fit(client, bank, [str(twice)], objective="window")
    said = [str(w.message) for w in here]
    assert any("(sampling.skip_out_of_order)" in message for message in said), said
    assert [str(w.message) for w in there] == said


def test_fit_with_each_modes_own_output_noise_on_the_cluster_equals_the_local_fit(client, configs, tmp_path):
    bank = configs / "realistic" / "stc_traction4.yaml"
    logs = []
    for seed in (21, 22):
        path = tmp_path / f"slip_FR_RR_{seed}.csv"
        skidimm.simulate(configs / "scenarios" / "realistic" / "stc_singular_slip_FR_RR.yaml", seed=seed,
                         duration=12.0, output=path)
        logs.append(f"slip_FR_RR={path}")
    options = dict(objective="window", window=1.0, hold_unexcited=True, output_noise=True)
    here = skidimm.fit(bank, logs, **options)
    there = skidimm.dask.fit(client, bank, logs, **options)

    def body(text):
        return [line for line in text.splitlines() if not line.startswith("# ")]

    assert body(there["bank_yaml"]) == body(here["bank_yaml"])
    assert there["entries"] == here["entries"]
