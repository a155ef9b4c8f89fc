"""Imm.checkpoint() and Imm.restore(): a filter carried across processes (pickled, or through the files of
`skidimm run --save-checkpoint`) goes on exactly as the one that never stopped."""

import math
import pickle

import numpy as np
import pytest
import yaml

import skidimm
from example_log import EXAMPLE, arrays


def test_a_pickled_checkpoint_restored_in_a_new_imm_goes_on_bit_for_bit(configs):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    t, u, z = arrays(configs, bank)
    whole = skidimm.Imm(bank).run(t, u, z)
    first = skidimm.Imm(bank)
    head = first.run(t[:400], u[:400], z[:400])
    checkpoint = pickle.loads(pickle.dumps(first.checkpoint()))
    assert checkpoint.t == t[399] and checkpoint.started
    assert checkpoint.mode_probabilities.tolist() == [head[f"mu_{m}"][399] for m in bank.modes]
    assert checkpoint.decision == head["decision"][399]
    second = skidimm.Imm(skidimm.Bank(configs / "ltc_terrains.yaml"))
    second.restore(checkpoint)
    rest = second.run(t[400:], u[400:], z[400:], reset=False)
    for name in ["mu_asphalt", "mu_grass", "mu_crushed_concrete", "V", "omega", "var_V", "var_omega"]:
        np.testing.assert_array_equal(np.concatenate([head[name], rest[name]]), whole[name], err_msg=name)
    assert list(head["decision"]) + list(rest["decision"]) == list(whole["decision"])
    # Step by step from the same checkpoint: the same.
    third = skidimm.Imm(bank)
    third.restore(checkpoint)
    for k in range(400, 420):
        e = third.step(t[k], u[k], z[k])
        assert e.mode_probabilities.tolist() == [whole[f"mu_{m}"][k] for m in bank.modes]
        assert e.decision == whole["decision"][k]


def test_a_checkpoint_of_the_cli_goes_on_in_python_and_its_file_is_plain_yaml(tmp_path, configs, cli):
    bank = skidimm.Bank(configs / "ltc_terrains.yaml")
    lines = (configs / EXAMPLE).read_text().splitlines()
    (tmp_path / "head.csv").write_text("\n".join(lines[:601]) + "\n")
    state = tmp_path / "state.yaml"
    cli("run", "-q", "--bank", configs / "ltc_terrains.yaml", "--input", tmp_path / "head.csv", "--output",
        tmp_path / "head_out.csv", "--save-checkpoint", state)
    checkpoint = skidimm.Checkpoint.load(state)
    t, u, z = arrays(configs, bank)
    imm = skidimm.Imm(bank)
    imm.restore(checkpoint)
    rest = imm.run(t[600:], u[600:], z[600:], reset=False)
    whole = skidimm.Imm(bank).run(t, u, z)
    np.testing.assert_array_equal(rest["mu_grass"], whole["mu_grass"][600:])
    assert list(rest["decision"]) == list(whole["decision"][600:])

    # PyYAML, a reader nobody here wrote, reads the file's numbers as the doubles themselves.
    document = yaml.safe_load(state.read_text())
    assert document["skidimm_checkpoint"] == 1
    assert document["bank"]["modes"] == list(bank.modes)
    assert document["t"] == checkpoint.t == t[599]
    assert document["estimate"]["mode_probabilities"] == checkpoint.mode_probabilities.tolist()
    assert document["estimate"]["state"] == checkpoint.state.tolist()
    assert document["decision"]["decision"] == checkpoint.decision
    # A step that measured nothing leaves NaN likelihoods: written as YAML's .nan.
    imm.step(t[-1] + 1.0, u[-1], [math.nan, math.nan])
    saved = tmp_path / "later.yaml"
    imm.checkpoint().save(saved)
    later = yaml.safe_load(saved.read_text())
    assert all(math.isnan(v) for v in later["estimate"]["log_likelihoods"])
    assert skidimm.Checkpoint.load(saved).text == saved.read_text()


def test_another_banks_checkpoint_is_refused_and_the_imm_is_left_as_it_was(configs, tmp_path):
    ltc = skidimm.Bank(configs / "ltc_terrains.yaml")
    t, u, z = arrays(configs, ltc)
    imm = skidimm.Imm(ltc)
    imm.run(t[:50], u[:50], z[:50])
    before = imm.checkpoint().text
    other = skidimm.Imm(skidimm.Bank(configs / "stc_slip4.yaml")).checkpoint()
    with pytest.raises(skidimm.Error, match=r"it was made by a bank of modes \[no_slip, "):
        imm.restore(other)
    assert imm.checkpoint().text == before
    broken = tmp_path / "broken.yaml"
    broken.write_text(before.replace("status: updated", "status: fine"))
    with pytest.raises(skidimm.ConfigError, match="estimate.status: not a step status: 'fine'") as error:
        skidimm.Checkpoint.load(broken)
    assert error.value.field == "estimate.status" and error.value.line > 1
