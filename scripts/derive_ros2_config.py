#!/usr/bin/env python3
"""Writes configs/borealtc/terrains_ros2.yaml from configs/borealtc/terrains.yaml.

The same bank (states, model, noise, modes: every section but `columns:`),
reading a BorealTC run recorded as a ROS 2 bag the way a Husky driver
publishes it (docs/ros2.md):

  /imu/data      sensor_msgs/msg/Imu:        wx, wy, wz = angular_velocity.x/y/z,
                                             ax, ay, az = linear_acceleration.x/y/z
  /joint_states  sensor_msgs/msg/JointState: name [left, right],
                                             velL, velR = velocity[left], velocity[right],
                                             curL, curR = effort[left], effort[right]

with the time from each message's header.stamp, and the terrain label (the
truth, when a bag has one) from a std_msgs/msg/String topic /terrain. A
driver's header.stamp can step back a few milliseconds now and then (a
stamp taken on another thread, a clock slewed by NTP); the bag bank leaves
such a message out (sampling.skip_out_of_order, counted in run's summary)
instead of stopping the run, which one IMU message of the 50 in a step
hardly changes.

Whenever terrains.yaml is refitted, run this again; the test
RosBags.TerrainsRos2IsDerivedFromTerrains (tests/CMakeLists.txt)
fails while the two differ anywhere but in `columns:` and that key.

    python3 scripts/derive_ros2_config.py          # rewrites terrains_ros2.yaml
    python3 scripts/derive_ros2_config.py --check  # exit 1 (and a diff) if it is not what this writes
"""
import argparse
import difflib
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "..", "configs", "borealtc", "terrains.yaml")
TARGET = os.path.join(HERE, "..", "configs", "borealtc", "terrains_ros2.yaml")

# The CSV columns of a BorealTC run and the bag fields that carry them.
FIELDS = {
    "velL": "/joint_states.velocity[left]",
    "velR": "/joint_states.velocity[right]",
    "curL": "/joint_states.effort[left]",
    "curR": "/joint_states.effort[right]",
    "wx": "/imu/data.angular_velocity.x",
    "wy": "/imu/data.angular_velocity.y",
    "wz": "/imu/data.angular_velocity.z",
    "ax": "/imu/data.linear_acceleration.x",
    "ay": "/imu/data.linear_acceleration.y",
    "az": "/imu/data.linear_acceleration.z",
}
TIME = "header.stamp"
TRUTH = "/terrain.data"


def split_columns(text):
    """(before, the columns: block, after): the block is the top-level key and its indented lines."""
    lines = text.splitlines(keepends=True)
    start = next(i for i, line in enumerate(lines) if line.startswith("columns:"))
    end = start + 1
    while end < len(lines) and (lines[end].startswith((" ", "\t")) or not lines[end].strip()):
        end += 1
    return "".join(lines[:start]), "".join(lines[start:end]), "".join(lines[end:])


def translate(expression):
    # Whole names only: "wz" in "mean(wz)", not in a longer name.
    return re.sub(r"\b[A-Za-z_][A-Za-z0-9_]*\b", lambda m: FIELDS.get(m.group(0), m.group(0)), expression)


def ros2_columns(block):
    out = []
    for line in block.splitlines(keepends=True):
        m = re.match(r'^(\s+)(time|truth_mode):\s*(\S+)(.*)$', line.rstrip("\n"))
        if m:
            value = TIME if m.group(2) == "time" else TRUTH
            out.append(f'{m.group(1)}{m.group(2)}: {value}{m.group(4)}\n')
            continue
        m = re.match(r'^(\s+\w+:\s*)"([^"]*)"(.*)$', line.rstrip("\n"))
        if m:
            out.append(f'{m.group(1)}"{translate(m.group(2))}"{m.group(3)}\n')
            continue
        out.append(line)
    return "".join(out)


SKIP_OUT_OF_ORDER = ("  skip_out_of_order: true                # a message whose header.stamp is not after its "
                     "topic's last is left out, counted in run's summary\n")


def ros2_sampling(text):
    """The sampling: block with skip_out_of_order: true added as its last key."""
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.startswith("sampling:")), None)
    if start is None:
        sys.exit(f"{SOURCE}: no top-level sampling: block after columns: to add skip_out_of_order to")
    end = start + 1
    while end < len(lines) and lines[end].startswith((" ", "\t")):
        end += 1
    if any("skip_out_of_order" in line for line in lines[start:end]):
        return text
    return "".join(lines[:end] + [SKIP_OUT_OF_ORDER] + lines[end:])


def derive(source_text):
    before, block, after = split_columns(source_text)
    after = ros2_sampling(after)
    header = ("# Derived from terrains.yaml by scripts/derive_ros2_config.py (do not edit: rerun it): the same\n"
              "# bank reading a ROS 2 bag, /imu/data (sensor_msgs/msg/Imu) and /joint_states\n"
              "# (sensor_msgs/msg/JointState, name [left, right]), time from header.stamp (docs/ros2.md);\n"
              "# a message stamped out of order is left out (sampling.skip_out_of_order), not an error.\n")
    return header + before + ros2_columns(block) + after


def main():
    # An unknown option is an error, not a rewrite of terrains_ros2.yaml.
    parser = argparse.ArgumentParser(description="Writes configs/borealtc/terrains_ros2.yaml from terrains.yaml "
                                                 "(every section but columns: and one key of sampling:).")
    parser.add_argument("--check", action="store_true",
                        help="write nothing: exit 1, with a diff, if terrains_ros2.yaml is not what this writes")
    arguments = parser.parse_args()
    with open(SOURCE) as f:
        wanted = derive(f.read())
    if arguments.check:
        current = open(TARGET).read() if os.path.exists(TARGET) else ""
        if current != wanted:
            sys.stdout.writelines(difflib.unified_diff(current.splitlines(True), wanted.splitlines(True),
                                                       "terrains_ros2.yaml", "derived from terrains.yaml"))
            print("configs/borealtc/terrains_ros2.yaml is not derived from terrains.yaml: "
                  "run python3 scripts/derive_ros2_config.py", file=sys.stderr)
            return 1
        return 0
    with open(TARGET, "w") as f:
        f.write(wanted)
    return 0


if __name__ == "__main__":
    sys.exit(main())
