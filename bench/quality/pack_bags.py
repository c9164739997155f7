#!/usr/bin/python3
"""Packs an image list into ROS bags and checks that placedb decides on them as on the list.

usage: bench/quality/pack_bags.py LIST OUT_DIR [--build build]

Writes OUT_DIR/compressed.bag (ROS 1, the image files as sensor_msgs/CompressedImage, with ROS's
own Python writer), OUT_DIR/raw.bag (ROS 1, bgr8 sensor_msgs/Image) and OUT_DIR/ros2/ (a ROS 2
bag folder, bgr8, laid out as rosbag2's sqlite3 storage writes it); maps the list and each bag
with `placedb map --log`, and prints, per bag, how many log cells differ from the list's run in
any column but the times and stamp_ns. Message i is stamped 1700000000 + i s and i us. Needs
Debian's python3-rosbag and python3-sensor-msgs, and the placedb Python module of the build.
"""
import argparse
import csv
import os
import sqlite3
import struct
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TIMES = {'time_ms', 'features_ms', 'quantisation_ms', 'likelihood_ms', 'filter_ms', 'memory_ms',
         'storage_ms', 'verification_ms', 'stamp_ns'}


def cdr_align(buf):
    while (len(buf) - 4) % 4:
        buf += b'\0'


def cdr_string(buf, text):
    cdr_align(buf)
    buf += struct.pack('<I', len(text) + 1) + text.encode() + b'\0'


def image_cdr(i, img):
    """sensor_msgs/msg/Image in CDR little-endian, after its 4-byte encapsulation header."""
    buf = bytearray(b'\0\1\0\0') + struct.pack('<iI', 1700000000 + i, i * 1000)
    cdr_string(buf, 'camera')
    cdr_align(buf)
    buf += struct.pack('<II', img.shape[0], img.shape[1])
    cdr_string(buf, 'bgr8')
    buf += b'\0'  # is_bigendian
    cdr_align(buf)
    buf += struct.pack('<I', img.shape[1] * 3) + struct.pack('<I', img.size) + img.tobytes()
    return bytes(buf)


def write_bags(placedb, paths, out):
    import genpy
    import rosbag
    from sensor_msgs.msg import CompressedImage, Image

    with rosbag.Bag(os.path.join(out, 'compressed.bag'), 'w') as packed, \
            rosbag.Bag(os.path.join(out, 'raw.bag'), 'w') as raw:
        for i, path in enumerate(paths):
            stamp = genpy.Time(1700000000 + i, i * 1000)
            with open(path, 'rb') as f:
                msg = CompressedImage(format=os.path.splitext(path)[1][1:], data=f.read())
            msg.header.stamp = stamp
            packed.write('/camera/image/compressed', msg, t=stamp)
            img = placedb.read_image(path)
            msg = Image(height=img.shape[0], width=img.shape[1], encoding='bgr8', is_bigendian=0,
                        step=img.shape[1] * 3, data=img.tobytes())
            msg.header.stamp = stamp
            raw.write('/camera/image_raw', msg, t=stamp)
    folder = os.path.join(out, 'ros2')
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, 'metadata.yaml'), 'w') as f:
        f.write('rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n')
    db = sqlite3.connect(os.path.join(folder, 'ros2_0.db3'))
    db.executescript(
        'CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,'
        'serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);'
        'CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,'
        'timestamp INTEGER NOT NULL, data BLOB NOT NULL);'
        "INSERT INTO topics VALUES (1, '/camera/image_raw', 'sensor_msgs/msg/Image', 'cdr', '');")
    for i, path in enumerate(paths):
        db.execute('INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?, ?)',
                   ((1700000000 + i) * 10**9 + i * 1000, image_cdr(i, placedb.read_image(path))))
    db.commit()


def differing_cells(expected, actual):
    a = list(csv.DictReader(open(expected)))
    b = list(csv.DictReader(open(actual)))
    if len(a) != len(b):
        return f'{len(a)} rows against {len(b)}'
    return sum(1 for x, y in zip(a, b) for k in x if k not in TIMES and x[k] != y[k])


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('list')
    p.add_argument('out')
    p.add_argument('--build', default=os.path.join(ROOT, 'build'))
    args = p.parse_args()
    sys.path.insert(0, os.path.join(args.build, 'python'))
    import placedb
    os.makedirs(args.out, exist_ok=True)
    write_bags(placedb, placedb.image_paths(args.list), args.out)
    binary = os.path.join(args.build, 'tools', 'placedb')
    runs = {'list': args.list}
    for name in ('compressed.bag', 'raw.bag', 'ros2'):
        runs[name] = os.path.join(args.out, name)
    for name, source in runs.items():
        map_path = os.path.join(args.out, name.replace('.', '_') + '.placedb')
        for leftover in (map_path, os.path.join(args.out, name + '.csv')):
            if os.path.exists(leftover):
                os.remove(leftover)
        subprocess.run([binary, 'map', map_path, source, '-q', '--log',
                        os.path.join(args.out, name + '.csv')], check=True)
    for name in ('compressed.bag', 'raw.bag', 'ros2'):
        print(f'{name}: {differing_cells(os.path.join(args.out, "list.csv"), os.path.join(args.out, name + ".csv"))} '
              'differing log cells against the list (times and stamp_ns aside)')


if __name__ == '__main__':
    main()
