#!/usr/bin/python3
"""placedb_node against a real ROS master (issue #49), beside `placedb map` on the same frames.

1. rtabmap_samples (84 frames), packed into a ROS 1 bag of CompressedImages with a camera_info
   topic (f = 420 px), played by `rosbag play` into the node started by ros/launch/placedb.launch
   (drop_frames off). The closures it publishes, its per-frame log and its map's relative poses
   equal those of `placedb map` on the bag with the same intrinsics; its query service answers
   a revisit as `placedb query` does, and an image that does not decode with an error.
2. lip6_outdoor's frames 0, 2, ..., 598 (the first 300 of frames_half.txt: its first 300
   frames hold no loop, the first revisit is frame 460), published by this script from a bag:
   the node is killed (SIGKILL) after frame 149, started again, resumes session 1 at frame 150,
   and ends with the CLI's closures, log and one cleanly closed session.
3. rtabmap_samples published as fast as possible into a node that drops frames: every frame is
   either mapped or counted as dropped.
4. rtabmap_samples' first 30 frames into a map on ctest's PostgreSQL server, the intrinsics
   given in ~settings: the log equals the CLI's first 30 rows.

Exit 77 (ctest: skipped) with a message where ROS 1, the node or the data sets are absent.
Usage: ros_node_test.py PLACEDB NODE PACKAGE_DIR MSGS_PYTHON_DIR LAUNCH_FILE WORK_DIR DATASETS
"""
import csv
import json
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time
import xmlrpc.client

FAILURES = []
# Columns that differ between two runs of the same decisions.
TIMES = {'time_ms', 'features_ms', 'quantisation_ms', 'likelihood_ms', 'filter_ms', 'memory_ms',
         'storage_ms', 'verification_ms'}
# Longest wait for the node or the master to get somewhere: a hang fails instead of stalling.
PATIENCE_S = 120


def check(ok, what):
    print(('ok      ' if ok else 'FAILED  ') + what, flush=True)
    if not ok:
        FAILURES.append(what)
    return ok


def skip(why):
    print('skipped: ' + why, flush=True)
    sys.exit(77)


def wait_until(condition, what):
    deadline = time.monotonic() + PATIENCE_S
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError('gave up waiting for ' + what)
        time.sleep(0.02)


def frame_paths(list_file, count):
    folder = os.path.dirname(list_file)
    with open(list_file) as f:
        lines = [line.strip() for line in f if line.strip() and not line.startswith('#')]
    return [os.path.join(folder, line) for line in lines[:count]]


def write_bag(paths, out, topic, info_topic=None, k=None):
    """Each image file as a CompressedImage, stamped 1700000000 + i s and i us, as the other bag
    tests do; a CameraInfo with intrinsics K beside each when `info_topic` is given."""
    import genpy
    import rosbag
    from sensor_msgs.msg import CameraInfo, CompressedImage

    with rosbag.Bag(out, 'w') as bag:
        for i, path in enumerate(paths):
            stamp = genpy.Time(1700000000 + i, i * 1000)
            with open(path, 'rb') as f:
                msg = CompressedImage(format=os.path.splitext(path)[1][1:], data=f.read())
            msg.header.stamp, msg.header.seq, msg.header.frame_id = stamp, i, 'camera'
            if info_topic:
                info = CameraInfo(K=k, P=k[:3] + [0] + k[3:6] + [0] + k[6:] + [0])
                info.header = msg.header
                bag.write(info_topic, info, t=stamp)
            bag.write(topic, msg, t=stamp)


def read_log(path):
    with open(path, newline='') as f:
        return list(csv.DictReader(f))


def same_log(node_log, cli_log, what):
    a, b = read_log(node_log), read_log(cli_log)
    if not check(len(a) == len(b), f'{what}: node log has {len(a)} rows, the CLI\'s {len(b)}'):
        return
    differing = [(row['frame'], key) for row, other in zip(a, b) for key in other
                 if key not in TIMES and row.get(key) != other[key]]
    check(not differing, f'{what}: node log equals the CLI log but for the times '
          f'({len(differing)} cells differ: {differing[:5]})')


def closures_of_log(path):
    """(frame, matched frames, score, inliers) of each accepted row of a placedb log."""
    out = []
    for row in read_log(path):
        if row['accepted'] == '1':
            frames = [int(v) for v in row['candidate_frames'].split()]
            out.append((int(row['frame']), frames, float(row['score']), int(row['inliers'])))
    return out


def closures_of_messages(messages):
    return [(m.index, [f.index for f in m.frames], m.score, m.inliers)
            for m in sorted(messages, key=lambda m: m.index)]


def same_scores(a, b):
    """Closure lists equal, scores to the log's printed precision."""
    return len(a) == len(b) and all(
        x[:2] == y[:2] and x[3] == y[3] and abs(x[2] - y[2]) <= 1e-6 * max(1.0, abs(y[2]))
        for x, y in zip(a, b))


def db_rows(path, sql):
    with sqlite3.connect(f'file:{path}?mode=ro', uri=True) as db:
        return db.execute(sql).fetchall()


def server_map(name):
    """A fresh database on ctest's PostgreSQL server, or None (said) when there is none."""
    uri_file = os.environ.get('PLACEDB_TEST_PG_URI_FILE', '')
    line = open(uri_file).read().strip() if uri_file and os.path.exists(uri_file) else ''
    if not line.startswith('postgresql://'):
        print(f'skipped: a map on a server: no PostgreSQL server ({line or "run through ctest"})')
        return None
    for sql in (f'DROP DATABASE IF EXISTS {name} WITH (FORCE)', f'CREATE DATABASE {name}'):
        subprocess.run(['psql', line, '-XAtqc', sql], check=True, capture_output=True)
    return line.replace('/placedb?', f'/{name}?')


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


class Listener:
    """This script's subscriptions to one node's topics: its closures and frames."""

    def __init__(self, rospy, msgs, node):
        self.closures, self.frames = [], []
        self.subs = [rospy.Subscriber(f'/{node}/loop_closures', msgs.LoopClosure,
                                      self.closures.append, queue_size=1000),
                     rospy.Subscriber(f'/{node}/frames', msgs.FrameStatus, self.frames.append,
                                      queue_size=1000)]

    def connected(self):
        return all(s.get_num_connections() > 0 for s in self.subs)

    def seen(self, index):
        return any(f.index == index for f in self.frames)

    def close(self):
        for s in self.subs:
            s.unregister()


# Every process the test starts, each in a session of its own, so that a failure anywhere still
# ends them and their children (roslaunch's nodes) rather than leaving them to the next test.
CHILDREN = []


def spawn(args, **kwargs):
    process = subprocess.Popen(args, start_new_session=True, **kwargs)
    CHILDREN.append(process)
    return process


def end_children():
    for process in CHILDREN:
        if process.poll() is None:
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            process.wait()


def stop(process, what, sig=signal.SIGINT):
    process.send_signal(sig)
    try:
        out = process.communicate(timeout=PATIENCE_S)[0]
    except subprocess.TimeoutExpired:
        process.kill()
        out = process.communicate()[0]
    if sig == signal.SIGINT:
        check(process.returncode == 0, f'{what}: exit {process.returncode} on SIGINT '
              f'(expected 0) {out.strip()[-600:]}')
    return out


def main(argv):
    placedb, node, package_dir, msgs_dir, launch_file, work, datasets = argv[1:8]
    if not node or not os.path.exists(node):
        skip('placedb_node was not built: ROS 1 is absent (scripts/install-deps.sh installs '
             'libroscpp-dev, libtopic-tools-dev, ros-sensor-msgs, python3-gencpp ...)')
    for tool in ('rosmaster', 'rosbag', 'roslaunch'):
        if not shutil.which(tool):
            skip(f'{tool} is not installed (python3-rosmaster, python3-rosbag, python3-roslaunch)')
    rtab_list = os.path.join(datasets, 'rtabmap_samples', 'frames.txt')
    lip6_list = os.path.join(datasets, 'lip6_outdoor', 'frames_half.txt')
    if not (os.path.exists(rtab_list) and os.path.exists(lip6_list)):
        skip(f'the data sets are absent ({datasets}: rtabmap_samples, lip6_outdoor)')
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    w = lambda name: os.path.join(work, name)  # noqa: E731

    port = free_port()
    master_uri = f'http://127.0.0.1:{port}/'
    os.environ.update({'ROS_MASTER_URI': master_uri, 'ROS_HOSTNAME': '127.0.0.1',
                       'ROS_HOME': w('ros_home'), 'ROS_LOG_DIR': w('ros_log'),
                       'ROS_PACKAGE_PATH': package_dir})
    sys.path.insert(0, msgs_dir)
    import rospy
    import placedb_msgs.msg as msgs
    from placedb_msgs.srv import Query, QueryRequest
    from sensor_msgs.msg import CompressedImage

    started = time.monotonic()
    rtab_k = [420.0, 0.0, 256.0, 0.0, 420.0, 192.0, 0.0, 0.0, 1.0]
    rtab_bag, lip6_bag = w('rtabmap.bag'), w('lip6.bag')
    write_bag(frame_paths(rtab_list, 84), rtab_bag, '/cam/image/compressed', '/cam/camera_info',
              rtab_k)
    write_bag(frame_paths(lip6_list, 300), lip6_bag, '/lip6/image/compressed')
    intrinsics = ['--set', 'fx=420', '--set', 'fy=420', '--set', 'cx=256', '--set', 'cy=192']
    for bag, name, extra in ((rtab_bag, 'rtab', intrinsics), (lip6_bag, 'lip6', [])):
        subprocess.run([placedb, 'map', w(f'cli_{name}.placedb'), bag, '--log',
                        w(f'cli_{name}.csv'), '-q', *extra], check=True)
    print(f'bags and CLI runs: {time.monotonic() - started:.1f} s', flush=True)

    master = spawn(['rosmaster', '--core', '-p', str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    try:
        proxy = xmlrpc.client.ServerProxy(master_uri)

        def master_up():
            try:
                return proxy.getSystemState('/ros_node_test')[0] == 1
            except OSError:
                return False
        wait_until(master_up, 'rosmaster')
        rospy.init_node('ros_node_test', disable_signals=True)
        helped = subprocess.run([node, '--help'], capture_output=True, text=True)
        check(helped.returncode == 0 and '~loop_closures' in helped.stdout and
              'Exit status' in helped.stdout, 'placedb_node --help: topics, parameters, exits')
        unset = subprocess.run([node, '__name:=placedb_unset'], capture_output=True, text=True)
        check(unset.returncode == 2 and unset.stderr.count('\n') == 1 and
              '~map is not set' in unset.stderr,
              f'no ~map: exit {unset.returncode} (expected 2), {unset.stderr.strip()}')

        # 1. rtabmap_samples: roslaunch + rosbag play.
        t0 = time.monotonic()
        listener = Listener(rospy, msgs, 'placedb')
        launch = spawn(
            ['roslaunch', launch_file, f'map:={w("node_rtab.placedb")}',
             'image:=/cam/image/compressed', 'camera_info:=/cam/camera_info',
             'drop_frames:=false', f'log:={w("node_rtab.csv")}', 'camera_info_wait:=120'],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        rospy.wait_for_service('/placedb/query', timeout=PATIENCE_S)
        wait_until(listener.connected, "the launched node's topics")
        subprocess.run(['rosbag', 'play', '-q', '-r', '40', '--wait-for-subscribers', rtab_bag],
                       check=True, stdout=subprocess.DEVNULL)
        wait_until(lambda: listener.seen(83), 'the node to map frame 83 of rtabmap_samples')
        check(closures_of_messages(listener.closures) and same_scores(
            closures_of_messages(listener.closures), closures_of_log(w('cli_rtab.csv'))),
              f'rtabmap_samples: the node published {len(listener.closures)} closures, equal '
              f'to the CLI\'s {len(closures_of_log(w("cli_rtab.csv")))}')
        cli_poses = db_rows(w('cli_rtab.placedb'), 'select source_index, pose_qx, pose_qy, '
                            'pose_qz, pose_qw, pose_tx, pose_ty, pose_tz from '
                            'v_loop_closure_poses order by source_index')
        node_poses = [(m.index, m.pose.orientation.x, m.pose.orientation.y,
                       m.pose.orientation.z, m.pose.orientation.w, m.pose.position.x,
                       m.pose.position.y, m.pose.position.z)
                      for m in sorted(listener.closures, key=lambda m: m.index) if m.has_pose]
        check(cli_poses and node_poses == [tuple(r) for r in cli_poses],
              f'rtabmap_samples: {len(node_poses)} published relative poses equal the CLI map\'s '
              f'{len(cli_poses)}')
        stamps_ok = all(m.header.stamp.secs == 1700000000 + m.index and
                        m.matched.stamp.secs == 1700000000 + m.matched.index and
                        m.header.frame_id == 'camera' for m in listener.closures)
        check(stamps_ok, 'rtabmap_samples: each closure carries both frames\' stamps')

        query = rospy.ServiceProxy('/placedb/query', Query)
        probe = frame_paths(rtab_list, 84)[70]
        with open(probe, 'rb') as f:
            answer = query(QueryRequest(compressed=CompressedImage(format='jpeg', data=f.read()),
                                        top=5))
        cli = json.loads(subprocess.run([placedb, 'query', w('cli_rtab.placedb'), probe, '--json'],
                                        check=True, capture_output=True, text=True).stdout)[0]
        got = (answer.verdict, answer.searched, answer.checked,
               [(m.location, m.tier, m.inliers, m.verified, [f.index for f in m.frames])
                for m in answer.matches])
        want = (cli['verdict'], cli['searched'], cli['checked'],
                [(m['location'], m['tier'], m['inliers'], m['verified'],
                  [f['source_index'] for f in m['frames']]) for m in cli['matches']])
        check(not answer.error and got == want and want[0] == 'known',
              f'query service on frame 70: {got[0]} {got[3][:2]}, as placedb query: '
              f'{want[0]} {want[3][:2]} {answer.error}')
        bad = query(QueryRequest(compressed=CompressedImage(format='jpeg', data=b'not a jpeg')))
        check(bad.verdict == '' and 'cannot be read' in bad.error,
              f'query service on bytes that do not decode: error "{bad.error}"')
        out = stop(launch, 'rtabmap_samples node (roslaunch)')
        listener.close()
        same_log(w('node_rtab.csv'), w('cli_rtab.csv'), 'rtabmap_samples')
        check(db_rows(w('node_rtab.placedb'), 'select count(*), min(clean_close) from sessions')
              == [(1, 1)], 'rtabmap_samples: one session, closed cleanly on shutdown')
        print(f'rtabmap_samples through roslaunch and rosbag play: {time.monotonic() - t0:.1f} s',
              flush=True)

        # 2. lip6_outdoor, every second frame up to 598, killed after frame 149 and resumed.
        t0 = time.monotonic()
        import rosbag
        messages = [m for _, m, _ in rosbag.Bag(lip6_bag).read_messages()]
        node_args = [node, 'image:=/lip6/image/compressed', '__name:=placedb_lip6',
                     f'_map:={w("node_lip6.placedb")}', f'_log:={w("node_lip6.csv")}',
                     '_drop_frames:=false', '_camera_info_wait:=0']
        closures = []
        for first, last, end in ((0, 149, 'kill'), (150, 299, 'shutdown')):
            listener = Listener(rospy, msgs, 'placedb_lip6')
            pub = rospy.Publisher('/lip6/image/compressed', CompressedImage, queue_size=1000)
            process = spawn(node_args, stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
            wait_until(lambda: listener.connected() and pub.get_num_connections() > 0,
                       'the lip6 node to connect')
            for message in messages[first:last + 1]:
                pub.publish(message)
            accepted = lambda: {f.index for f in listener.frames if f.closure}  # noqa: E731
            wait_until(lambda: listener.seen(last) and accepted() <= {
                c.index for c in listener.closures}, f'the lip6 node to map frame {last}')
            closures += listener.closures
            out = stop(process, 'lip6 node', signal.SIGKILL if end == 'kill' else signal.SIGINT)
            pub.unregister()
            listener.close()
            if end == 'kill':
                check(db_rows(w('node_lip6.placedb'), 'select max(source_index) from frames')
                      == [(149,)], 'lip6: the killed node\'s map holds frames 0-149')
            else:
                check('resuming session 1' in out and 'from frame 150' in out,
                      f'lip6: the node started again resumes session 1 at frame 150 '
                      f'({out.strip().splitlines()[:1]})')
        check(closures and same_scores(closures_of_messages(closures),
                                       closures_of_log(w('cli_lip6.csv'))),
              f'lip6 (300 frames, killed after 149): the node published {len(closures)} '
              f'closures, equal to the CLI\'s {len(closures_of_log(w("cli_lip6.csv")))}')
        same_log(w('node_lip6.csv'), w('cli_lip6.csv'), 'lip6 killed and resumed')
        check(db_rows(w('node_lip6.placedb'), 'select count(*), min(clean_close) from sessions')
              == [(1, 1)], 'lip6: one session, killed, resumed and closed cleanly')
        print(f'lip6 killed and resumed: {time.monotonic() - t0:.1f} s', flush=True)

        # 3. Dropping frames: every frame is mapped or counted.
        t0 = time.monotonic()
        rtab = [m for topic, m, _ in rosbag.Bag(rtab_bag).read_messages()
                if topic == '/cam/image/compressed']
        listener = Listener(rospy, msgs, 'placedb_drop')
        pub = rospy.Publisher('/drop/image/compressed', CompressedImage, queue_size=1000)
        process = spawn([node, 'image:=/drop/image/compressed', '__name:=placedb_drop',
                                    f'_map:={w("node_drop.placedb")}', '_camera_info_wait:=0'],
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wait_until(lambda: listener.connected() and pub.get_num_connections() > 0,
                   'the dropping node to connect')
        for message in rtab:
            pub.publish(message)
        wait_until(lambda: any(f.index + 1 + f.dropped == len(rtab) for f in listener.frames),
                   'every frame mapped or dropped')
        done = max(listener.frames, key=lambda f: f.index)
        stop(process, 'dropping node')
        pub.unregister()
        listener.close()
        mapped = db_rows(w('node_drop.placedb'), 'select count(*) from frames')[0][0]
        check(mapped == done.index + 1 and mapped + done.dropped == len(rtab),
              f'drop_frames: {mapped} frames mapped + {done.dropped} dropped = {len(rtab)} '
              f'published')
        print(f'dropping frames: {time.monotonic() - t0:.1f} s', flush=True)
        # 4. A map on a PostgreSQL server (ctest's pg_server fixture), intrinsics in ~settings.
        t0 = time.monotonic()
        uri = server_map('ros_node_test')
        if uri:
            listener = Listener(rospy, msgs, 'placedb_pg')
            pub = rospy.Publisher('/pg/image/compressed', CompressedImage, queue_size=1000)
            process = spawn(
                [node, 'image:=/pg/image/compressed', '__name:=placedb_pg', f'_map:={uri}',
                 f'_log:={w("node_pg.csv")}', '_drop_frames:=false',
                 '_settings:=fx=420 fy=420 cx=256 cy=192'],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            wait_until(lambda: listener.connected() and pub.get_num_connections() > 0,
                       'the server map node to connect')
            for message in rtab[:30]:
                pub.publish(message)
            wait_until(lambda: listener.seen(29), 'the server map node to map frame 29')
            stop(process, 'server map node')
            pub.unregister()
            listener.close()
            with open(w('cli_rtab.csv')) as f, open(w('cli_rtab_30.csv'), 'w') as out:
                out.writelines(f.readlines()[:31])
            same_log(w('node_pg.csv'), w('cli_rtab_30.csv'), 'a map on a server, 30 frames')
            print(f'a map on a server: {time.monotonic() - t0:.1f} s', flush=True)
    finally:
        rospy_module = sys.modules.get('rospy')
        if rospy_module:
            rospy_module.signal_shutdown('test over')
        master.terminate()
        master.wait()
        end_children()
    print(f'total {time.monotonic() - started:.1f} s; ' +
          (f'{len(FAILURES)} FAILED' if FAILURES else 'all passed'), flush=True)
    return 1 if FAILURES else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
