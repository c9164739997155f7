#!/usr/bin/python3
"""Writes a ROS 1 bag with the ROS project's own writer (Debian's python3-rosbag), for the tests.

usage: write_ros1_bag.py OUT.bag TOPIC KIND ENCODING FRAME...

KIND is raw (sensor_msgs/Image) or compressed (sensor_msgs/CompressedImage). A raw FRAME file
holds a line "WIDTH HEIGHT STEP" and then the pixel bytes, already in ENCODING; a compressed
FRAME file holds the compressed image (ENCODING is its format, e.g. png). Message i gets
header.stamp = 1700000000 + i seconds and i * 1000 nanoseconds, and the same record time. An
extra topic (/odom_note, std_msgs/String) is written beside the images, as real bags have.
"""
import sys

import genpy
import rosbag
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import String


def main(argv):
    out, topic, kind, encoding, frames = argv[1], argv[2], argv[3], argv[4], argv[5:]
    with rosbag.Bag(out, 'w') as bag:
        for i, path in enumerate(frames):
            stamp = genpy.Time(1700000000 + i, i * 1000)
            with open(path, 'rb') as f:
                content = f.read()
            if kind == 'raw':
                line, pixels = content.split(b'\n', 1)
                width, height, step = (int(v) for v in line.split())
                msg = Image(height=height, width=width, encoding=encoding, is_bigendian=0,
                            step=step, data=pixels)
            else:
                msg = CompressedImage(format=encoding, data=content)
            msg.header.stamp = stamp
            msg.header.seq = i
            msg.header.frame_id = 'camera'
            bag.write(topic, msg, t=stamp)
            bag.write('/odom_note', String(data='frame %d' % i), t=stamp)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
