#!/usr/bin/env python3
"""write_db3.py: stores the messages of write_bag.mjs --jsonl in rosbag2's sqlite3 storage
(the default before ROS 2 Iron), with Python's own sqlite3 module, so that the bag's
database is written by code independent of SkiMap's reader (ros/bag/sqlite_bag.cc). The CDR
payloads are @foxglove/rosmsg2-serialization's.

  write_db3.py MESSAGES.jsonl OUT_DIR [--split N]

OUT_DIR becomes a rosbag2 folder: metadata.yaml and OUT_DIR_0.db3 (with --split N, a new
.db3 every N messages: a split recording). The tables are rosbag2's sqlite3 schema:
topics(id, name, type, serialization_format, offered_qos_profiles) and
messages(id, topic_id, timestamp, data), with the timestamp index.
"""
import base64
import json
import os
import sqlite3
import sys


def main(argv):
    if len(argv) not in (3, 5) or (len(argv) == 5 and argv[3] != '--split'):
        print(__doc__.strip().splitlines()[4], file=sys.stderr)
        return 2
    src, out = argv[1], argv[2]
    split = int(argv[4]) if len(argv) == 5 else 0
    messages = [json.loads(line) for line in open(src)]
    os.makedirs(out, exist_ok=True)
    name = os.path.basename(os.path.normpath(out))
    files, db, topics, count = [], None, {}, 0
    for m in messages:
        if db is None or (split and count % split == 0 and count > 0):
            if db is not None:
                db.commit()
                db.close()
            files.append(f'{name}_{len(files)}.db3')
            db = sqlite3.connect(os.path.join(out, files[-1]))
            db.executescript('''
              CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
              INSERT INTO schema VALUES (3, 'humble');
              CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
                                  serialization_format TEXT NOT NULL,
                                  offered_qos_profiles TEXT NOT NULL);
              CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
                                    timestamp INTEGER NOT NULL, data BLOB NOT NULL);
              CREATE INDEX timestamp_idx ON messages (timestamp ASC);''')
            topics = {}
        if m['topic'] not in topics:
            topics[m['topic']] = len(topics) + 1
            db.execute('INSERT INTO topics VALUES (?, ?, ?, ?, ?)',
                       (topics[m['topic']], m['topic'], m['type'], 'cdr', ''))
        db.execute('INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)',
                   (topics[m['topic']], int(m['ns']), base64.b64decode(m['cdr'])))
        count += 1
    db.commit()
    db.close()
    with open(os.path.join(out, 'metadata.yaml'), 'w') as f:
        f.write('rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n'
                f'  message_count: {count}\n  relative_file_paths:\n'
                + ''.join(f'    - {x}\n' for x in files))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
