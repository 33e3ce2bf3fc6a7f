"""kneesim's file formats from Python (python/io.cpp): .mot/.sto, TRC and C3D to and from NumPy,
against the files' own text or bytes read here independently (and a C3D file written here by
hand, byte by byte, following the C3D specification)."""

import struct

import numpy as np
import pytest

import kneesim
from conftest import data_path


def parse_storage_text(path):
    """Labels and rows of a .mot/.sto file, read without kneesim."""
    lines = path.read_text().splitlines()
    end = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
    labels = lines[end + 1].split()
    rows = [[float(v) for v in l.split()] for l in lines[end + 2:] if l.strip()]
    return labels, np.array(rows)


def parse_trc_text(path):
    """Marker labels, units and positions (frames x markers x 3, file units) of a TRC file."""
    lines = path.read_text().splitlines()
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    units = values[keys.index("Units")]
    labels = [c for c in lines[3].split("\t")[2:] if c.strip()]
    rows = [l.split("\t") for l in lines[5:] if l.strip()]
    data = np.array([[float(c) if c.strip() else np.nan for c in r[2:2 + 3 * len(labels)]] for r in rows])
    time = np.array([float(r[1]) for r in rows])
    return labels, units, time, data.reshape(len(rows), len(labels), 3)


def test_storage_reads_what_the_file_holds():
    path = data_path("opensim-ik-tests/std_subject01_walk1_ik.mot")
    st = kneesim.read_storage(str(path))
    labels, rows = parse_storage_text(path)
    assert st.labels == labels
    assert st.data.shape == rows.shape == (73, 24)
    np.testing.assert_array_equal(st.data, rows)
    assert st.in_degrees  # a SIMM motion file: degrees
    np.testing.assert_array_equal(st.column("knee_angle_r"), rows[:, labels.index("knee_angle_r")])
    assert not st.data.flags.writeable  # a copy: editing it in place would change nothing


def test_storage_round_trips_through_a_file(tmp_path):
    t = np.linspace(0, 1, 11)
    data = np.column_stack([t, np.sin(t), 1e-5 * np.cos(t), np.full_like(t, np.nan)])
    st = kneesim.Storage(["time", "a", "b", "c"], data, name="waves", in_degrees=True)
    path = tmp_path / "waves.sto"
    kneesim.write_storage(str(path), st)
    labels, rows = parse_storage_text(path)
    assert labels == ["time", "a", "b", "c"]
    text = path.read_text()
    assert text.startswith("waves\n") and "inDegrees=yes" in text and "nRows=11" in text
    # OpenSim's "%.8f", but 9 significant digits below 1e-3.
    big = np.abs(data[:, :3]) >= 1e-3
    np.testing.assert_allclose(rows[:, :3][big], data[:, :3][big], rtol=0, atol=5e-9)
    np.testing.assert_allclose(rows[:, :3][~big], data[:, :3][~big], rtol=5e-9, atol=0)
    assert np.isnan(rows[:, 3]).all()
    back = kneesim.read_storage(str(path))
    np.testing.assert_array_equal(back.data[:, :3], rows[:, :3])


def test_storage_errors_are_one_line_input_errors(tmp_path):
    path = tmp_path / "short_row.sto"
    path.write_text("x\nversion=1\nnRows=2\nnColumns=3\nendheader\ntime\ta\tb\n0\t1\t2\n0.1\t1\n")
    with pytest.raises(kneesim.InputError) as e:
        kneesim.read_storage(str(path))
    assert str(e.value) == f"{path}:8: expected 3 values (one per column label), got 2"
    assert e.value.line == 8 and e.value.element is None
    with pytest.raises(kneesim.InputError, match=r"expected 'time' as the first label, got 'a'"):
        kneesim.Storage(["a", "b"], np.zeros((2, 2)))
    with pytest.raises(kneesim.InputError, match=r"^Storage/data: expected an array of shape \(rows, 2 labels\), got \(2, 3\)$"):
        kneesim.Storage(["time", "b"], np.zeros((2, 3)))


def test_trc_reads_what_the_file_holds():
    path = data_path("opensim-ik-tests/subject01_synthetic_marker_data.trc")
    trc = kneesim.read_trc(str(path))
    labels, units, time, xyz = parse_trc_text(path)
    assert units == "m" and trc.original_units == "m"
    assert trc.labels == labels and trc.num_markers == 31 and trc.num_frames == 73
    assert trc.rate == 60.0
    np.testing.assert_array_equal(trc.time, time)
    np.testing.assert_array_equal(trc.positions, xyz)
    assert trc.find_marker("R.Heel") == labels.index("R.Heel")


def test_trc_writes_millimetres_and_missing_markers(tmp_path):
    rng = np.random.default_rng(7)
    p = rng.uniform(-1, 1, (5, 2, 3))
    p[3, 1] = np.nan
    table = kneesim.MarkerTable(p, ["A", "B"], rate=100.0)
    np.testing.assert_allclose(table.time, np.arange(5) / 100.0)
    path = tmp_path / "m.trc"
    kneesim.write_trc(str(path), table, units="mm")
    labels, units, time, xyz = parse_trc_text(path)
    assert labels == ["A", "B"] and units == "mm"
    np.testing.assert_allclose(xyz, 1000 * p, atol=1e-4)  # written with enough digits for 0.1 um
    assert np.isnan(xyz[3, 1]).all() and np.isfinite(xyz[3, 0]).all()
    np.testing.assert_allclose(kneesim.read_trc(str(path)).positions, p, atol=1e-7)


def test_trc_errors_are_input_errors(tmp_path):
    path = data_path("opensim-ik-tests/subject01_synthetic_marker_data.trc")
    cut = tmp_path / "cut.trc"
    cut.write_text("\n".join(path.read_text().splitlines()[:20]) + "\n")  # 14 of 73 frames
    with pytest.raises(kneesim.InputError) as e:
        kneesim.read_trc(str(cut))
    assert e.value.file == str(cut) and "73" in str(e.value)
    with pytest.raises(kneesim.InputError, match=r"positions: expected an array of shape \(frames, 2 markers, 3\), got \(5, 3\)"):
        kneesim.MarkerTable(np.zeros((5, 3)), ["A", "B"], rate=100.0)
    with pytest.raises(kneesim.InputError, match="expected time or rate"):
        kneesim.MarkerTable(np.zeros((5, 2, 3)), ["A", "B"])


# ---- C3D written by hand (Intel, float data): 2 points over 3 frames at 50 Hz, 2 analog channels
# at 2 samples per frame, one point missing in one frame.
POINTS_MM = np.array([[[10.0, 20.0, 30.0], [-1.5, 2.25, 1000.0]],
                      [[11.0, 21.0, 31.0], [np.nan, np.nan, np.nan]],
                      [[12.0, 22.0, 32.0], [-3.5, 4.25, 1002.0]]])
ANALOG_RAW = np.arange(12, dtype=float).reshape(6, 2) * 10 + 5  # samples x channels
ANALOG_SCALE, ANALOG_OFFSET, GEN_SCALE = [0.5, 2.0], [5, -3], 1.5


def c3d_param(group_id, name, type_, dims, data, desc=b""):
    body = bytes([type_ & 0xFF, len(dims)]) + bytes(dims) + data + bytes([len(desc)]) + desc
    return bytes([len(name), group_id]) + name + struct.pack("<h", 2 + len(body)) + body


def c3d_group(group_id, name, desc=b""):
    body = bytes([len(desc)]) + desc
    return bytes([len(name), (-group_id) & 0xFF]) + name + struct.pack("<h", 2 + len(body)) + body


def c3d_chars(words, width):
    return b"".join(w.encode().ljust(width) for w in words)


def write_hand_c3d(path):
    nf, npt, nch, spf, rate = 3, 2, 2, 2, 50.0
    f32 = lambda *v: struct.pack(f"<{len(v)}f", *v)
    i16 = lambda *v: struct.pack(f"<{len(v)}h", *v)
    params = b"".join([
        c3d_group(1, b"POINT"),
        c3d_param(1, b"USED", 2, [], i16(npt)),
        c3d_param(1, b"FRAMES", 2, [], i16(nf)),
        c3d_param(1, b"SCALE", 4, [], f32(-0.1)),
        c3d_param(1, b"RATE", 4, [], f32(rate)),
        c3d_param(1, b"DATA_START", 2, [], i16(3)),
        c3d_param(1, b"UNITS", -1, [2], b"mm"),
        c3d_param(1, b"LABELS", -1, [4, 2], c3d_chars(["LKNE", "RANK"], 4)),
        c3d_group(2, b"ANALOG"),
        c3d_param(2, b"USED", 2, [], i16(nch)),
        c3d_param(2, b"RATE", 4, [], f32(rate * spf)),
        c3d_param(2, b"GEN_SCALE", 4, [], f32(GEN_SCALE)),
        c3d_param(2, b"SCALE", 4, [2], f32(*ANALOG_SCALE)),
        c3d_param(2, b"OFFSET", 2, [2], i16(*ANALOG_OFFSET)),
        c3d_param(2, b"LABELS", -1, [3, 2], c3d_chars(["Fz1", "EMG"], 3)),
        c3d_param(2, b"UNITS", -1, [1, 2], b"NV"),
    ])
    params += bytes([0, 0]) + struct.pack("<h", 0)  # end of the parameter list
    section = bytes([1, 0x50, 1, 84]) + params  # 1 block, Intel
    assert len(section) <= 512
    header = bytes([2, 0x50]) + i16(npt, nch * spf, 1, nf, 0) + f32(-0.1) + i16(3, spf) + f32(rate)
    data = b""
    for k in range(nf):
        for p in POINTS_MM[k]:
            data += f32(0, 0, 0, -1) if np.isnan(p).any() else f32(*p, 0.0)
        for s in range(spf):
            data += f32(*ANALOG_RAW[k * spf + s])
    path.write_bytes(header.ljust(512, b"\0") + section.ljust(512, b"\0") + data.ljust(512, b"\0"))


def test_c3d_reads_a_file_written_by_hand(tmp_path):
    path = tmp_path / "hand.c3d"
    write_hand_c3d(path)
    c = kneesim.read_c3d(str(path))
    assert c.processor == "Intel"
    assert c.point_labels == ["LKNE", "RANK"] and c.point_rate == 50.0
    assert c.points.shape == (3, 2, 3)
    np.testing.assert_allclose(c.points, POINTS_MM / 1000, rtol=1e-7)  # mm -> m, NaN where missing
    assert np.isnan(c.residuals[1, 1]) and c.residuals[0, 0] == 0
    np.testing.assert_allclose(c.markers.time, [0, 0.02, 0.04])
    assert c.analog_labels == ["Fz1", "EMG"] and c.analog_units == ["N", "V"]
    assert c.analog_rate == 100.0 and c.analog.samples_per_frame == 2
    expected = (ANALOG_RAW - np.array(ANALOG_OFFSET)) * np.array(ANALOG_SCALE) * GEN_SCALE
    np.testing.assert_allclose(c.analog_data, expected, rtol=1e-7)
    assert c.find_parameter("point", "units").strings == ["mm"]
    assert c.find_parameter("POINT", "NOPE") is None


def test_c3d_written_from_numpy_has_the_header_the_standard_asks_for(tmp_path):
    rng = np.random.default_rng(3)
    pts = rng.uniform(-2, 2, (4, 3, 3))
    analog = rng.uniform(-100, 100, (12, 2))
    markers = kneesim.MarkerTable(pts, ["A", "B", "C"], rate=200.0)
    c3d = kneesim.C3d(markers, analog, analog_labels=["F", "M"], analog_units=["N", "Nmm"])
    assert c3d.analog_rate == 600.0
    path = tmp_path / "np.c3d"
    kneesim.write_c3d(str(path), c3d)
    raw = path.read_bytes()
    assert raw[1] == 0x50
    npt, per_frame, first, last = struct.unpack("<4h", raw[2:10])
    (scale,) = struct.unpack("<f", raw[12:16])
    (rate,) = struct.unpack("<f", raw[20:24])
    assert (npt, per_frame, first, last) == (3, 6, 1, 4)
    assert scale < 0 and rate == 200.0  # float data
    param_block = raw[0]
    assert raw[512 * (param_block - 1) + 3] == 84  # Intel
    back = kneesim.read_c3d(str(path))
    np.testing.assert_allclose(back.points, pts, atol=1e-6)  # float32 millimetres
    np.testing.assert_allclose(back.analog_data, analog, rtol=1e-6)
    assert back.analog_labels == ["F", "M"] and back.analog_units == ["N", "Nmm"]


def test_jw_c3d_matches_its_header_bytes():
    path = data_path("kgc4-jw/markers/jw_ngait_og3.c3d")
    raw = path.read_bytes()[:512]
    npt, per_frame, first, last = struct.unpack("<4h", raw[2:10])
    (spf,) = struct.unpack("<h", raw[18:20])
    (rate,) = struct.unpack("<f", raw[20:24])
    c = kneesim.read_c3d(str(path))
    assert len(c.point_labels) == npt and c.points.shape == (last - first + 1, npt, 3)
    assert c.point_rate == rate and c.analog_rate == rate * spf
    assert c.analog_data.shape == ((last - first + 1) * spf, per_frame // spf)
    assert len(c.analog_labels) == per_frame // spf
    assert c.first_frame == first
    # Markers in mm in the file, metres here: a lab a few metres across.
    assert 0.5 < np.nanmax(np.abs(c.points)) < 10


def test_c3d_errors_are_input_errors(tmp_path):
    path = tmp_path / "hand.c3d"
    write_hand_c3d(path)
    raw = path.read_bytes()
    bad_key = tmp_path / "bad_key.c3d"
    bad_key.write_bytes(raw[:1] + b"\x51" + raw[2:])
    with pytest.raises(kneesim.InputError) as e:
        kneesim.read_c3d(str(bad_key))
    assert e.value.file == str(bad_key) and "\n" not in str(e.value)
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(raw[:1024 + 40])  # data of one frame and a bit
    with pytest.raises(kneesim.InputError, match="truncated|expected"):
        kneesim.read_c3d(str(cut))
    markers = kneesim.MarkerTable(np.zeros((4, 1, 3)), ["A"], rate=100.0)
    with pytest.raises(kneesim.InputError, match=r"whole number of samples per marker frame \(4 frames\), got 6"):
        kneesim.C3d(markers, np.zeros((6, 1)))
