"""The placedb Python module: mapping numpy images, results, queries, info, loop closures,
vocabularies and errors. Run by ctest (python_module) with PYTHONPATH at the built module."""
import os
import pathlib

import numpy as np
import pytest

import placedb


def scene(seed):
    """A grey 320 x 240 image of discs: SURF finds corners and blobs that differ per seed."""
    rng = np.random.default_rng(seed)
    image = np.full((240, 320), 128, np.float32)
    yy, xx = np.mgrid[0:240, 0:320]
    for _ in range(60):
        cx, cy, r = rng.uniform(0, 320), rng.uniform(0, 240), rng.uniform(4, 30)
        image[(xx - cx) ** 2 + (yy - cy) ** 2 < r * r] = rng.uniform(0, 255)
    image += rng.normal(0, 6, image.shape)
    return np.clip(image, 0, 255).astype(np.uint8)


def write_png(path, image):
    """A grey 8-bit PNG, without OpenCV or PIL."""
    import struct
    import zlib

    raw = b"".join(b"\0" + row.tobytes() for row in image)

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff))
    header = struct.pack(">IIBBBBB", image.shape[1], image.shape[0], 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
                     chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def test_module_names_its_version_and_license():
    assert placedb.__version__.count(".") == 2
    assert placedb.__license__ == "BSD-3-Clause"
    root = pathlib.Path(__file__).resolve().parents[2]
    assert "BSD 3-Clause License" in (root / "LICENSE").read_text()


def test_reads_and_queries_image_files(tmp_path):
    for i in range(3):
        write_png(tmp_path / f"{i}.png", scene(i))
    image = placedb.read_image(str(tmp_path / "1.png"))
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    assert (image[:, :, 0] == scene(1)).all()
    path = str(tmp_path / "run.placedb")
    with placedb.Map(path) as m:
        m.begin_session(str(tmp_path))
        for i in range(3):
            m.process_file(str(tmp_path / f"{i}.png"))
    with placedb.Map(path, read_only=True) as m:
        result = m.query_file(str(tmp_path / "1.png"))
        assert result.matches
        assert any(f.source_index == 1 for f in result.matches[0].frames)
        assert result.verdict in ("known", "unknown")
        assert result.searched >= 1 and result.checked >= 1
        best = result.matches[0]
        assert best.tier in ("stm", "wm", "ltm")
        assert best.inliers >= 0 and isinstance(best.verified, bool)
        assert (result.verdict == "known") == best.verified
        with pytest.raises(placedb.IoError) as missing:
            m.query_file(str(tmp_path / "absent.png"))
        assert "absent.png" in str(missing.value)
    with pytest.raises(placedb.IoError):
        placedb.read_image(str(tmp_path / "absent.png"))


def test_maps_grey_and_bgr_images_and_reports_each_frame(tmp_path):
    path = str(tmp_path / "run.placedb")
    with placedb.Map(path) as m:
        session = m.begin_session("numpy")
        assert session.id == 1
        grey = m.process(scene(0))
        assert grey.source_index == 0
        assert grey.outcome in ("new_location", "merged")
        assert grey.feature_count > 0
        assert grey.times.total > 0
        bgr = np.dstack([scene(1)] * 3)
        colour = m.process(bgr, source_path="colour.png")
        assert colour.source_index == 1  # counts on from the previous frame
        assert colour.location_id > 0
        assert isinstance(colour.hypothesis.frames, list)
        assert colour.accepted is False and colour.score >= 0 and colour.inliers >= 0
        assert m.last_session().frames == 2
    info = placedb.info(path)
    assert info["frames"] == 2
    assert info["sessions"][0]["source"] == "numpy"


def test_revisited_views_close_loops_that_loop_closures_lists(tmp_path):
    path = str(tmp_path / "loop.placedb")
    first_pass = 24
    results = []
    with placedb.Map(path) as m:
        m.begin_session("tour")
        for seed in list(range(first_pass)) + list(range(8)):  # then the first 8 again
            results.append(m.process(scene(seed)))
    accepted = [r for r in results if r.accepted]
    assert accepted, [repr(r) for r in results]
    # A closure links a revisit to the location of the same view on the first pass.
    for r in accepted:
        assert r.source_index >= first_pass
        matched = [f.source_index for f in r.matched_frames]
        assert r.source_index - first_pass in matched, (repr(r), matched)
    rows = placedb.loop_closures(path)
    assert len(rows) >= len(accepted)
    assert {"location_a", "location_b", "score", "first_frame_a", "first_frame_b"} <= set(rows[0])
    assert all(row["session_a"] == row["session_b"] == 1 for row in rows)

    with placedb.Map(path, read_only=True) as m:
        found = m.query(scene(3), top=3)
        assert found.matches
        # Seed 3 was seen at frames 3 and first_pass + 3.
        best = {f.source_index for f in found.matches[0].frames}
        assert best & {3, first_pass + 3}, best
        assert m.loop_closures() == rows


def test_closures_carry_a_pose_only_with_intrinsics(tmp_path):
    camera = {"fx": 300.0, "fy": 300.0, "cx": 160.0, "cy": 120.0}
    for settings, posed in ((None, False), (camera, True)):
        path = str(tmp_path / f"pose-{posed}.placedb")
        with placedb.Map(path, settings=settings) as m:
            m.begin_session("tour")
            results = [m.process(scene(seed)) for seed in list(range(24)) + list(range(8))]
        accepted = [r for r in results if r.accepted]
        assert accepted
        poses = [r.hypothesis.pose for r in accepted]
        if not posed:
            assert all(p is None for p in poses)
            continue
        assert any(p is not None for p in poses), [repr(r) for r in accepted]
        for p in poses:
            if p is None:
                continue
            assert abs(sum(q * q for q in p["rotation_xyzw"]) - 1.0) < 1e-6
            assert p["inliers"] >= 5
        # Seen again from the same place: x, y, z near 0 and w near 1 (x, y, z, w order).
        still = next(p for p in poses if p is not None)
        assert len(still["rotation_xyzw"]) == 4
        # A query of a mapped image on a map with intrinsics answers with the pose too.
        with placedb.Map(path, read_only=True) as m:
            found = m.query(scene(3))
        assert found.verdict == "known"
        assert found.matches[0].pose is not None
        assert abs(found.matches[0].pose["rotation_xyzw"][3]) > 0.99
        # The names of `placedb query --json`, and the frame the pose is relative to.
        assert set(found.matches[0].pose) == {"rotation_xyzw", "translation", "inliers",
                                              "relative_to"}
        assert found.matches[0].pose["relative_to"].frame_id == \
            found.matches[0].frames[0].frame_id


def test_results_print_readably_and_carry_stamps(tmp_path):
    path = str(tmp_path / "stamps.placedb")
    stamp = 1_700_000_000_000_000_000
    with placedb.Map(path) as m:
        session = m.begin_session("tour")
        assert "object at" not in repr(session)
        assert repr(session).startswith("SessionInfo(id=1, source='tour'")
        results = [m.process(scene(seed), stamp_ns=stamp + i * 100_000_000)
                   for i, seed in enumerate(list(range(24)) + list(range(8)))]
        assert "object at" not in repr(m.sessions())
    accepted = [r for r in results if r.accepted]
    assert accepted
    for r in accepted:
        for f in r.matched_frames:
            assert f.stamp_ns == stamp + f.source_index * 100_000_000
            assert f"stamp_ns={f.stamp_ns}" in repr(f)
        assert "object at" not in repr(r.hypothesis)
        assert "frames=[1:" in repr(r.hypothesis)
    with placedb.Map(path, read_only=True) as m:
        found = m.query(scene(3))
    for shown in (found, found.matches[0], found.matches[0].frames[0]):
        assert "object at" not in repr(shown), repr(shown)
    assert repr(found).startswith("QueryResult(verdict='known'")
    # A verified match without intrinsics has no pose, and says why.
    assert found.matches[0].verified and found.matches[0].pose is None
    assert "no camera intrinsics" in found.matches[0].no_pose_reason
    assert found.matches[0].frames[0].stamp_ns is not None


def test_vocabulary_export_and_import_both_formats(tmp_path):
    path = str(tmp_path / "words.placedb")
    with placedb.Map(path) as m:
        m.begin_session("words")
        for seed in (0, 1, 2):
            m.process(scene(seed))
    words = placedb.info(path)["words"]
    assert words > 0
    for fmt, name in (("placedb", "words.pvoc"), ("rtabmap", "words.txt")):
        exported = str(tmp_path / name)
        assert placedb.vocab_export(path, exported, format=fmt) == words
        target = str(tmp_path / ("from-" + name + ".placedb"))
        assert placedb.vocab_import(exported, target, mode="seed", format=fmt) == words
        again = str(tmp_path / ("again-" + name))
        placedb.vocab_export(target, again, format=fmt)
        assert pathlib.Path(again).read_bytes() == pathlib.Path(exported).read_bytes()
    first_line = (tmp_path / "words.txt").read_text().splitlines()[0]
    assert first_line == "WordID Descriptors...64"


def test_errors_carry_the_exit_code_category(tmp_path):
    with pytest.raises(placedb.InvalidArgument) as bad_setting:
        placedb.Map(str(tmp_path / "a.placedb"), settings={"t_loop": "lots"})
    assert bad_setting.value.exit_code == 2
    assert bad_setting.value.category == "invalid_argument"
    assert "t_loop" in str(bad_setting.value)

    not_a_map = tmp_path / "notes.placedb"
    not_a_map.write_bytes(b"these are notes, not a map\n" * 100)
    before = not_a_map.read_bytes()
    with pytest.raises(placedb.MapRefused) as refused:
        placedb.Map(str(not_a_map))
    assert refused.value.exit_code == 4
    assert isinstance(refused.value, placedb.Error)
    assert not_a_map.read_bytes() == before

    with pytest.raises(placedb.IoError) as missing:
        placedb.info(str(tmp_path / "absent.placedb"))
    assert missing.value.exit_code == 3

    with pytest.raises(placedb.VocabularyRefused) as vocabulary:
        junk = tmp_path / "junk.pvoc"
        junk.write_bytes(b"definitely not a vocabulary")
        placedb.vocab_import(str(junk), str(tmp_path / "v.placedb"))
    assert vocabulary.value.exit_code == 8
    assert not (tmp_path / "v.placedb").exists()

    with placedb.Map(str(tmp_path / "b.placedb"), settings={"t_loop": 0.05, "upright": True}) as m:
        assert m.settings["t_loop"] == "0.05" and m.settings["upright"] == "true"
        m.begin_session("errors")
        with pytest.raises(placedb.InvalidArgument, match="dtype"):
            m.process(np.zeros((240, 320), dtype=np.int64))
        with pytest.raises(placedb.InvalidArgument, match="channels"):
            m.process(np.zeros((240, 320, 2), dtype=np.uint8))
        # Refused from its shape, before any copy: made contiguous this view of one byte would
        # be 10 GB (a MemoryError before).
        huge = np.lib.stride_tricks.as_strided(np.zeros(1, dtype=np.uint8),
                                               shape=(100000, 100000), strides=(0, 0))
        with pytest.raises(placedb.InvalidArgument, match="pixels a side"):
            m.process(huge)
        with pytest.raises(placedb.InvalidArgument, match="pixels a side"):
            m.query(huge)
    with pytest.raises(placedb.InvalidArgument, match="closed"):
        m.process(np.zeros((240, 320), dtype=np.uint8))


def test_maps_image_files_of_a_list_and_records_unreadable_ones(tmp_path):
    datasets = pathlib.Path(os.environ.get("PLACEDB_DATASETS_DIR", "../shared/datasets"))
    frames = datasets / "rtabmap_samples" / "frames.txt"
    if not frames.exists():
        pytest.skip(f"{frames} is absent")
    paths = placedb.image_paths(str(frames))
    assert len(paths) > 3
    broken = tmp_path / "broken.jpg"
    broken.write_bytes(b"not a jpeg")
    with placedb.Map(str(tmp_path / "files.placedb")) as m:
        m.begin_session(str(frames))
        results = [m.process_file(p) for p in paths[:3] + [str(broken)]]
    assert [r.source_index for r in results] == [0, 1, 2, 3]
    assert all(r.feature_count > 0 for r in results[:3])
    assert results[3].outcome == "bad"


def test_settings_catalogue():
    keys = {s["key"] for s in placedb.settings()}
    assert {"t_loop", "kd_trees", "word_rule"} <= keys


def test_one_map_is_safe_to_share_between_threads(tmp_path):
    import threading

    path = str(tmp_path / "threads.placedb")
    errors = []

    def run(fn):
        try:
            fn()
        except Exception as e:  # noqa: BLE001 - collected and asserted below
            errors.append(e)

    with placedb.Map(path) as m:
        m.begin_session("threads")
        workers = [threading.Thread(target=run, args=(lambda k=k: [m.process(scene(10 * k + i))
                                                                   for i in range(5)],))
                   for k in range(2)]
        for w in workers:
            w.start()
        for w in workers:
            w.join()
        assert not errors, errors
        assert m.last_session().frames == 10
        # Localising against the map being built is a separate, read-only Map.
        with pytest.raises(placedb.InvalidArgument) as writable:
            m.query(scene(0))
        assert "read-only" in str(writable.value)

    reader = placedb.Map(path, read_only=True)
    workers = [threading.Thread(target=run, args=(lambda: [reader.query(scene(i)) for i in
                                                           range(4)],)) for _ in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert not errors, errors

    # close() while another thread queries: it waits for the call in flight; later calls are
    # refused, never a crash.
    outcomes = []

    def query_until_closed():
        for i in range(20):
            try:
                reader.query(scene(i))
                outcomes.append("answered")
            except placedb.InvalidArgument as e:
                assert "closed" in str(e)
                outcomes.append("closed")

    worker = threading.Thread(target=query_until_closed)
    worker.start()
    reader.close()
    worker.join()
    assert len(outcomes) == 20


def test_frames_of_a_bag_keep_their_stamps(tmp_path):
    import sqlite3
    import subprocess

    for i in range(4):
        write_png(tmp_path / f"{i}.png", scene(i))
    folder = placedb.frames(str(tmp_path))
    assert folder.kind == "folder" and len(folder) == 4
    assert [index for index, _, _, _ in folder] == [0, 1, 2, 3]

    root = pathlib.Path(__file__).resolve().parents[2]
    bag = tmp_path / "images.bag"
    writer = subprocess.run(["/usr/bin/python3", str(root / "tests/cli/bags/write_ros1_bag.py"),
                             str(bag), "/camera/image", "compressed", "png"] +
                            [str(tmp_path / f"{i}.png") for i in range(4)],
                            capture_output=True, text=True)
    if writer.returncode != 0:
        pytest.skip(f"cannot write a ROS 1 bag here: {writer.stderr.strip()[-200:]}")
    frames = placedb.frames(str(bag), topic="/camera/image")
    assert frames.kind == "bag" and len(frames) == 4
    path = str(tmp_path / "bag.placedb")
    with placedb.Map(path) as m:
        m.begin_session(str(bag))
        for index, source_path, image, stamp_ns in frames:
            assert (image[:, :, 0] == scene(index)).all()
            assert stamp_ns == (1700000000 + index) * 10**9 + index * 1000
            m.process(image, index, source_path, stamp_ns=stamp_ns)
    with sqlite3.connect(path) as db:
        stamps = [row[0] for row in db.execute("SELECT stamp_ns FROM frames ORDER BY id")]
    assert stamps == [(1700000000 + i) * 10**9 + i * 1000 for i in range(4)]
    with pytest.raises(placedb.InvalidArgument):
        placedb.frames(str(tmp_path), topic="/camera/image")
