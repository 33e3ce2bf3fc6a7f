"""Readers of JW's real inputs for the independent stress generator (issue 17): the paper workflow's
contact-area .sto, the eKnee knee-force CSV and the force plates of a C3D file.

Written apart from kneesim's engine on purpose (plain Python 3, no numpy, no engine code): the stress
suite's trials must not share a code path with what they test.
"""

import math
import struct

LBF = 4.4482216152605  # N per pound-force (the eKnee's load cells are in lbf)
# Dao & Pouletaut's equation 4 (Zhao et al. 2007): medial/lateral force from the cells AM, PM, AL, PL.
EQ4_MEDIAL = (0.9871, 0.9683, 0.0387, 0.0211)
EQ4_LATERAL = (0.0129, 0.0317, 0.9613, 0.9789)
CSV_GRF_NEWTONS_PER_UNIT = 2000.0  # JW's GRFz column: force plate 1's vertical force / 2000


def read_sto(path):
    """Columns of an OpenSim-style .sto as {label: [values]} (header up to 'endheader')."""
    with open(path) as f:
        lines = f.read().splitlines()
    k = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
    labels = lines[k + 1].split()
    cols = {lab: [] for lab in labels}
    for line in lines[k + 2:]:
        parts = line.split()
        if len(parts) != len(labels):
            continue
        for lab, v in zip(labels, parts):
            cols[lab].append(float(v))
    return cols


def read_eknee_csv(path):
    """The eKnee CSV: (header labels, rows of floats). Handles CR, LF or CRLF line ends and the
    trailing comma of JW's files."""
    with open(path, newline=None) as f:
        lines = [l for l in f.read().splitlines() if l.strip()]
    header = [h.strip() for h in lines[0].split(",") if h.strip()]
    rows = []
    for l in lines[1:]:
        vals = [v for v in l.split(",") if v.strip()]
        rows.append([float(v) for v in vals[: len(header)]])
    return header, rows


def column(header, rows, name):
    i = next(k for k, h in enumerate(header) if h.lower().startswith(name.lower()))
    return [r[i] for r in rows]


def total_force_n(header, rows):
    """Measured total force (N): equation 4's medial + lateral, i.e. the sum of the four cells."""
    am, pm, al, pl = (column(header, rows, c) for c in ("AM", "PM", "AL", "PL"))
    out = []
    for cells in zip(am, pm, al, pl):
        out.append(sum((EQ4_MEDIAL[k] + EQ4_LATERAL[k]) * cells[k] for k in range(4)) * LBF)
    return out


def cells_for(medial_n, lateral_n):
    """Load cells (AM, PM, AL, PL in lbf) giving these compartment forces under equation 4, with
    AM = PM and AL = PL (two unknowns, two equations)."""
    a = EQ4_MEDIAL[0] + EQ4_MEDIAL[1]
    b = EQ4_MEDIAL[2] + EQ4_MEDIAL[3]
    c = EQ4_LATERAL[0] + EQ4_LATERAL[1]
    d = EQ4_LATERAL[2] + EQ4_LATERAL[3]
    det = a * d - b * c
    m = (d * medial_n - b * lateral_n) / det
    l_ = (a * lateral_n - c * medial_n) / det
    return m / LBF, m / LBF, l_ / LBF, l_ / LBF


# ---------------------------------------------------------------- C3D force plates
def _params(data, block):
    """The C3D parameter section as {(GROUP, PARAM): value}; Intel processor only."""
    p = (block - 1) * 512
    if data[p + 3] != 84:
        raise ValueError("only Intel C3D files are read here (processor type %d)" % data[p + 3])
    groups, raw = {}, []
    i = p + 4
    while True:
        nlen = struct.unpack_from("b", data, i)[0]
        gid = struct.unpack_from("b", data, i + 1)[0]
        if nlen == 0:
            break
        name = data[i + 2:i + 2 + abs(nlen)].decode("latin-1").upper()
        j = i + 2 + abs(nlen)
        nxt = struct.unpack_from("<h", data, j)[0]
        body = j + 2
        if gid < 0:
            groups[-gid] = name
        else:
            dtype = struct.unpack_from("b", data, body)[0]
            ndim = data[body + 1]
            dims = list(data[body + 2:body + 2 + ndim])
            q = body + 2 + ndim
            count = 1
            for dd in dims:
                count *= dd
            size = abs(dtype)
            if dtype == -1:  # characters: a list of strings of dims[0] characters
                if ndim <= 1:
                    val = [data[q:q + count].decode("latin-1").strip()]
                else:
                    w = dims[0]
                    val = [data[q + k * w:q + (k + 1) * w].decode("latin-1").strip() for k in range(count // w)]
            else:
                fmt = {1: "B", 2: "<h", 4: "<f"}[size]
                val = [struct.unpack_from(fmt, data, q + k * size)[0] for k in range(count)]
            raw.append((gid, name, val))
        if nxt == 0:
            break
        i = j + nxt
    return {(groups.get(g, "?"), n): v for g, n, v in raw}


def read_plate_vertical(path):
    """Vertical force (N, >= 0) of every force plate of a C3D file, averaged over each video
    frame's analog samples: (frame times in s, [per plate: per frame force]). Plates of type 2 or 4
    (Fx Fy Fz Mx My Mz); the Fz channel is scaled by ANALOG:SCALE x GEN_SCALE after OFFSET, signed
    so that the largest load is positive."""
    data = open(path, "rb").read()
    n_points, analog_per_frame, first, last = struct.unpack_from("<hhhh", data, 2)
    scale = struct.unpack_from("<f", data, 12)[0]
    start_block = struct.unpack_from("<h", data, 16)[0]
    rate = struct.unpack_from("<f", data, 20)[0]
    if scale >= 0:
        raise ValueError("integer C3D data are not read here")
    P = _params(data, data[0])
    n_analog = int(P[("ANALOG", "USED")][0])
    per_frame = analog_per_frame // n_analog
    a_scale = P[("ANALOG", "SCALE")]
    a_off = P[("ANALOG", "OFFSET")]
    gen = P[("ANALOG", "GEN_SCALE")][0]
    units = P.get(("ANALOG", "UNITS"), [""] * n_analog)
    n_plates = int(P[("FORCE_PLATFORM", "USED")][0])
    chans = P[("FORCE_PLATFORM", "CHANNEL")]
    n_frames = last - first + 1
    stride = n_points * 4 + analog_per_frame
    base = (start_block - 1) * 512
    plates = []
    for p in range(n_plates):
        ch = int(chans[p * 6 + 2]) - 1  # Fz
        unit = {"N": 1.0, "KN": 1000.0, "LBF": LBF}.get(units[ch].upper(), 1.0) if ch < len(units) else 1.0
        per = []
        for f in range(n_frames):
            off = base + 4 * (f * stride + n_points * 4)
            s = 0.0
            for k in range(per_frame):
                v = struct.unpack_from("<f", data, off + 4 * (k * n_analog + ch))[0]
                s += (v - a_off[ch]) * a_scale[ch] * gen * unit
            per.append(s / per_frame)
        sign = 1.0 if max(per) >= -min(per) else -1.0
        plates.append([max(0.0, sign * v) for v in per])
    times = [(first + f - 1) / rate for f in range(n_frames)]
    return times, plates


def interp(xs, ys, x):
    """Linear interpolation of (xs, ys) at x, xs increasing; constant beyond the ends."""
    if x <= xs[0]:
        return ys[0]
    if x >= xs[-1]:
        return ys[-1]
    lo, hi = 0, len(xs) - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    u = (x - xs[lo]) / (xs[hi] - xs[lo])
    return ys[lo] + u * (ys[hi] - ys[lo])


def moving_average(x, half):
    """Centred moving average over 2 half + 1 samples (shorter at the ends)."""
    n = len(x)
    out = []
    for i in range(n):
        a, b = max(0, i - half), min(n, i + half + 1)
        out.append(sum(x[a:b]) / (b - a))
    return out


def central_rate(t, x):
    """dx/dt by central differences (one-sided at the ends)."""
    n = len(x)
    out = []
    for i in range(n):
        a, b = max(0, i - 1), min(n - 1, i + 1)
        out.append((x[b] - x[a]) / (t[b] - t[a]))
    return out


def rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else float("nan")
