#!/usr/bin/env python3
"""Writes a rosbag2 SQLite bag (DIR/NAME_0.db3 and DIR/metadata.yaml) from
the messages write_borealtc_bag.cjs serialized (a .jsonl file), the way
rosbag2 lays it out: tables topics and messages with its timestamp index;
with --definitions also schema, metadata and message_definitions, as from
Iron on (without it, as Humble writes: no definitions, the reader uses its
bundled ones). Standard library only.

  write_db3.py MESSAGES.jsonl BAG_DIRECTORY [--definitions] [--no-metadata]
"""
import base64
import json
import os
import sqlite3
import sys


def main():
    source, bag = sys.argv[1], sys.argv[2]
    definitions = "--definitions" in sys.argv
    os.makedirs(bag, exist_ok=True)
    name = os.path.basename(os.path.normpath(bag)) + "_0.db3"
    path = os.path.join(bag, name)
    if os.path.exists(path):
        os.remove(path)
    with open(source) as f:
        head = json.loads(f.readline())
        messages = [json.loads(line) for line in f if line.strip()]
    db = sqlite3.connect(path)
    if definitions:
        db.execute("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL)")
        db.execute("INSERT INTO schema VALUES (4, 'jazzy')")
        db.execute("CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,"
                   "metadata TEXT NOT NULL)")
        db.execute("CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
                   "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL,"
                   "type_description_hash TEXT NOT NULL)")
        db.execute("CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,"
                   "encoding TEXT NOT NULL,encoded_message_definition TEXT NOT NULL,"
                   "type_description_hash TEXT NOT NULL)")
    else:
        db.execute("CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
                   "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL)")
    db.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
               "timestamp INTEGER NOT NULL, data BLOB NOT NULL)")
    db.execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC)")
    ids = {}
    for i, topic in enumerate(head["topics"], start=1):
        ids[topic["name"]] = i
        if definitions:
            db.execute("INSERT INTO topics VALUES (?,?,?,?,?,?)", (i, topic["name"], topic["type"], "cdr", "", ""))
            db.execute("INSERT INTO message_definitions VALUES (?,?,?,?,?)",
                       (i, topic["type"], "ros2msg", topic["definition"], ""))
        else:
            db.execute("INSERT INTO topics VALUES (?,?,?,?,?)", (i, topic["name"], topic["type"], "cdr", ""))
    counts = {t["name"]: 0 for t in head["topics"]}
    for m in messages:
        db.execute("INSERT INTO messages(topic_id, timestamp, data) VALUES (?,?,?)",
                   (ids[m["topic"]], int(m["timestamp"]), base64.b64decode(m["data"])))
        counts[m["topic"]] += 1
    db.commit()
    db.close()
    if "--no-metadata" in sys.argv:
        return
    start = min(int(m["timestamp"]) for m in messages)
    end = max(int(m["timestamp"]) for m in messages)
    lines = ["rosbag2_bagfile_information:", "  version: 5", "  storage_identifier: sqlite3",
             "  duration:", f"    nanoseconds: {end - start}", "  starting_time:",
             f"    nanoseconds_since_epoch: {start}", f"  message_count: {len(messages)}",
             "  topics_with_message_count:"]
    for t in head["topics"]:
        lines += ["    - topic_metadata:", f"        name: {t['name']}", f"        type: {t['type']}",
                  "        serialization_format: cdr", "        offered_qos_profiles: \"\"",
                  f"      message_count: {counts[t['name']]}"]
    lines += ["  compression_format: \"\"", "  compression_mode: \"\"", "  relative_file_paths:", f"    - {name}",
              "  files:", f"    - path: {name}", "      starting_time:", f"        nanoseconds_since_epoch: {start}",
              "      duration:", f"        nanoseconds: {end - start}", f"      message_count: {len(messages)}"]
    with open(os.path.join(bag, "metadata.yaml"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
