#!/usr/bin/env python3
"""Writes a Foxglove layout (File > Import layout) that shows skidimm's
estimates for a bank: the mode probabilities, the most likely mode and the
decision over time, the combined state, and the raw messages, all from the
topic /skidimm/estimate that `skidimm run --output estimates.mcap` and
`skidimm run --serve PORT` publish (docs/foxglove.md). Standard library only:
the bank's mode and state names are read from its `states:` line and its
`- name:` entries under `modes:`.

    python3 scripts/foxglove_layout.py configs/borealtc/terrains_ros2.yaml > docs/foxglove/borealtc_terrains.json
    python3 scripts/foxglove_layout.py --check BANK.yaml LAYOUT.json   # exit 1 unless LAYOUT is what this writes
"""
import json
import re
import sys

TOPIC = "/skidimm/estimate"


def names(bank_text):
    states = re.search(r"^states:\s*\[([^\]]*)\]", bank_text, re.M).group(1)
    modes_block = bank_text[re.search(r"^modes:\s*$", bank_text, re.M).end():]
    modes = re.findall(r"^\s*-\s*name:\s*([A-Za-z0-9_.-]+)", modes_block, re.M)
    return [s.strip() for s in states.split(",")], modes


def plot(title, paths, y_range=None):
    config = {
        "title": title,
        "paths": [{"value": p, "enabled": True, "timestampMethod": "receiveTime"} for p in paths],
        "showXAxisLabels": True,
        "showYAxisLabels": True,
        "showLegend": True,
        "legendDisplay": "floating",
        "isSynced": True,
        "xAxisVal": "timestamp",
    }
    if y_range:
        config["minYValue"], config["maxYValue"] = y_range
    return config


def layout(bank_text):
    states, modes = names(bank_text)
    panels = {
        "Plot!probabilities": plot("Mode probabilities", [f"{TOPIC}.probability.{m}" for m in modes], (0, 1)),
        "StateTransitions!decision": {
            "paths": [{"value": f"{TOPIC}.decision", "timestampMethod": "receiveTime"},
                      {"value": f"{TOPIC}.mode", "timestampMethod": "receiveTime"},
                      {"value": f"{TOPIC}.status", "timestampMethod": "receiveTime"}],
            "isSynced": True,
        },
        "Plot!state": plot("Combined state", [f"{TOPIC}.state.{s}" for s in states]),
        "RawMessages!estimate": {"topicPath": TOPIC, "diffEnabled": False, "expansion": "auto"},
    }
    return {
        "configById": panels,
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {
            "direction": "row",
            "first": {"direction": "column", "first": "Plot!probabilities",
                      "second": {"direction": "column", "first": "StateTransitions!decision", "second": "Plot!state",
                                 "splitPercentage": 40},
                      "splitPercentage": 50},
            "second": "RawMessages!estimate",
            "splitPercentage": 72,
        },
    }


def main():
    if sys.argv[1] == "--check":
        wanted = json.dumps(layout(open(sys.argv[2]).read()), indent=2) + "\n"
        if open(sys.argv[3]).read() != wanted:
            print(f"{sys.argv[3]} is not the layout of {sys.argv[2]}: rerun scripts/foxglove_layout.py", file=sys.stderr)
            return 1
        return 0
    sys.stdout.write(json.dumps(layout(open(sys.argv[1]).read()), indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
